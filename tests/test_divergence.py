"""A vehicle whose closed loop diverges (here the paper's vehicles with a 1 s step) stops the run with one line in
both engines, or is lost as a dead process is under on_vehicle_loss = continue; never a traceback or a hang."""

from __future__ import annotations

import re

import pytest

from tests.conftest import shortened
from tests.procs import cpf

pytestmark = pytest.mark.e2e
DIVERGES = ["--set", "scenario.step=1", "--quiet"]


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_a_diverging_vehicle_stops_the_run_with_one_line(tmp_path, paper_text, engine):
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened(paper_text, 10.0))
    done = cpf("run", str(scenario), "--engine", engine, "--out", "r.mcap", *DIVERGES, cwd=tmp_path, timeout=120)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.startswith("cpf: error")]  # (and the warning that
    # the shortened run ends before the paper's fault)
    # Every vehicle diverges in the same step; over Zenoh whichever process exits first is the one named.
    assert len(lines) == 1, lines
    stopped = re.match(r"cpf: error: vehicle (\d) stopped at t = 1\.0 s", lines[0])
    assert stopped is not None, lines
    assert f"vehicle {stopped[1]} diverged at t = 1.0 s: its speed is" in lines[0]


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_a_diverging_vehicle_is_lost_when_the_scenario_says_continue(tmp_path, paper_text, engine):
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened(paper_text, 10.0))
    args = ["--set", "scenario.on_vehicle_loss=continue", "--engine", engine, "--out", "r.mcap", *DIVERGES]
    done = cpf("run", str(scenario), *args, cwd=tmp_path, timeout=120)
    assert "Traceback" not in done.stderr
    assert re.search(r"vehicle \d lost at t = 1\.0 s", done.stderr) and "diverged" in done.stderr, done.stderr

"""A vehicle that lies (issue 29), through a user's extension as a faulty vehicle stack would: vehicle 2's law asks
for a rate of 1e6 once its gamma passes 133 (tests.samples.laws:LiesAbove). The Zenoh engine finds its state
implausible (comms.records.plausible) before it reaches the log or another vehicle, and names it; under
on_vehicle_loss = continue the run goes on without it and its process is stopped (it went on stepping and
transmitting, each message dropped and counted).

Zenoh only: plausibility guards the bus against a process the supervisor does not control; the in-process engine has
no bus and no such process, and does not check (checking there stopped runs whose loop really diverges, which it
reports as diverged: supervisor.analysis.divergence)."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest

from supervisor.config.plausibility import plausibility
from supervisor.config.scenario import load_scenario
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, shortened
from tests.procs import ROOT, cpf

pytestmark = pytest.mark.e2e
ENV = {"PYTHONPATH": str(ROOT)}  # tests.samples importable in every process of the run
LIAR = ["--set", "coordination.law=tests.samples.laws:LiesAbove", "--set", 'saturation.correction="none"', "--quiet"]
SECONDS = 40.0


def run(tmp_path: Path, engine: str, on_loss: str) -> tuple[subprocess.CompletedProcess[str], Path]:
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), SECONDS))
    args = ["run", str(scenario), "--engine", engine, "--out", "r.mcap", "--metrics", "m.json", *LIAR]
    done = cpf(*args, "--set", f"scenario.on_vehicle_loss={on_loss}", cwd=tmp_path, env=ENV, timeout=180)
    assert "Traceback" not in done.stderr, done.stderr
    return done, scenario


def test_a_lying_vehicle_stops_the_run_naming_it(tmp_path: Path) -> None:
    done, _ = run(tmp_path, "zenoh", "abort")
    errors = [line for line in done.stderr.splitlines() if line.startswith("cpf: error")]
    assert done.returncode == 1 and len(errors) == 1, done.stderr
    assert re.match(
        r"cpf: error: vehicle 2 sent a state the run cannot use at t = \d+\.\d s \(implausible: ", errors[0]
    )


def test_a_lying_vehicle_is_taken_out_and_nothing_it_said_gets_through(tmp_path: Path) -> None:
    done, scenario = run(tmp_path, "zenoh", "continue")
    assert done.returncode == 0, done.stderr
    lost = re.search(
        r"vehicle 2 lost at t = (\d+\.\d) s \(it sent a state the run cannot use: implausible", done.stderr
    )
    assert lost is not None, done.stderr
    bounds = plausibility(load_scenario(scenario))
    last: dict[int, float] = {}
    for topic, _, m in read_messages(tmp_path / "r.mcap"):
        if re.fullmatch(r"cpf/vehicle/\d+/(state|tx)", topic):
            assert abs(m["gamma_dot"]) <= bounds[m["vehicle"] if "vehicle" in m else m["sender"]].gamma_dot, m
        if topic.endswith("/state"):
            last[m["vehicle"]] = m["t"]
        if topic.endswith("/rx"):
            assert all(abs(h["gamma_dot"]) <= bounds[h["sender"]].gamma_dot for h in m["receptions"]), m
    assert last[1] == last[3] == pytest.approx(SECONDS - 0.1) and last[2] < float(lost[1])
    # Found at once, then stopped: a handful of its messages dropped, not one per step for the rest of the run.
    drops = json.loads((tmp_path / "m.json").read_text()).get("dropped_by_cause", {})
    assert drops["vehicle 2"] is None  # taken out: it sent no report, and its drops are unknown, not none
    dropped = sum(n for causes in drops.values() if causes is not None for n in causes.values())
    assert dropped < 0.1 * (SECONDS - float(lost[1])) / 0.1, drops

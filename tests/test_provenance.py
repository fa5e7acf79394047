"""Reports say what they are drawn from (issue 30, item 4): a recovered log, how much of its source was kept and
lost; a resim log, which log and which settings changed; and no panel is drawn without data (a resim log holds
states alone: no packets, no delays)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

from supervisor import cli
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from tests.conftest import CONFIGS, shortened

DURATION = 10.0


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    scenario = parse_scenario(text, "configs/paper.toml", ["faults.0.start=3", "faults.0.end=6"])
    path = tmp_path_factory.mktemp("provenance") / "run.mcap"
    run_inprocess(scenario, "configs/paper.toml", text, path, 1, Progress(DURATION, io.StringIO(), enabled=False))
    return path


def report(log: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> tuple[list[str], dict]:
    assert cli.main(["report", str(log), "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    return lines, json.loads((out / "metrics.json").read_text())


def test_a_runs_own_report_says_nothing_of_the_kind(log, tmp_path, capsys):
    lines, metrics = report(log, tmp_path / "own", capsys)
    assert metrics["drawn_from"] is None and not any("drawn from" in line for line in lines)
    assert (tmp_path / "own" / "comms_packets.png").exists()


def test_a_recovered_logs_report_says_how_much_was_lost(log, tmp_path, capsys):
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[: log.stat().st_size // 2])
    fixed = tmp_path / "fixed.mcap"
    assert cli.main(["recover", str(cut), "--out", str(fixed)]) == 0
    capsys.readouterr()
    lines, metrics = report(fixed, tmp_path / "rec", capsys)
    said = f"{fixed}: drawn from a log recovered from {cut}: "
    assert lines[0].startswith(said) and "unreadable bytes dropped" in lines[0] and "last log time" in lines[0]
    assert metrics["drawn_from"] == lines[0].removeprefix(f"{fixed}: ")


def test_a_resim_logs_report_says_what_changed_and_draws_no_empty_panel(log, tmp_path, capsys):
    resim = tmp_path / "resim.mcap"
    assert cli.main(["resim", str(log), "--set", "coordination.k=0.3", "--out", str(resim)]) == 0
    capsys.readouterr()
    lines, metrics = report(resim, tmp_path / "resim", capsys)
    assert lines[0] == (
        f"{resim}: drawn from a re-simulation of {log} (--set coordination.k=0.3): states only, no channel records"
    )
    assert metrics["drawn_from"] == lines[0].removeprefix(f"{resim}: ")
    assert not (tmp_path / "resim" / "comms_packets.png").exists()
    assert not (tmp_path / "resim" / "comms_delay_histogram.png").exists()
    assert (tmp_path / "resim" / "fig5_coordination_errors.png").exists()

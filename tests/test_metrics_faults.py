"""What `cpf report`'s metrics.json says of a run's faults: the reconvergence time the printed summary gives (its
"below ... again from t = ..." line, also when the last fault never ends: metrics.json had null), and each fault as
the scenario has it (it had only kind, start and end: no vehicle, no offset).

    paper.toml, 20 s: gamma_offset 0.001 on vehicle 2 from 10 s (no end); a broker_kill 4-5 s
"""

from __future__ import annotations

import pytest

from supervisor.analysis.metrics import run_metrics, run_series
from supervisor.analysis.rundata import load_run
from supervisor.analysis.summary import summarize
from supervisor.cli import main
from tests.conftest import CONFIGS

FAULTS = "faults=[{kind='gamma_offset',vehicle=2,offset=0.001,start=10.0},{kind='broker_kill',start=4.0}]"


@pytest.fixture(scope="module")
def metrics(tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("run") / "run.mcap"
    sets = ["--set", FAULTS, "--set", "scenario.duration=20", "--set", "report.coordination_tolerance=100"]
    assert main(["run", str(CONFIGS / "paper.toml"), "--engine", "inprocess", "--out", str(out), "--quiet", *sets]) == 0
    run = load_run(out)
    summary = summarize(
        run_series(run), 20.0, [("broker_kill", 4.0, 4.1), ("gamma_offset", 10.0, 20.0)], 50.0, 1.2, 100.0
    )
    return {**run_metrics(run), "summary": summary}


def test_the_reconvergence_time_is_the_printed_one_when_the_last_fault_never_ends(metrics: dict) -> None:
    """Within tolerance all along: from the start of the last phase, as the summary prints it."""
    assert metrics["summary"].resync_time == pytest.approx(10.0)
    assert metrics["coordination"]["reconvergence_time"] == pytest.approx(10.0)


def test_the_faults_are_in_the_settings_as_the_scenario_has_them(metrics: dict) -> None:
    """Every field of the scenario's fault, the end as the phases take it: the run's end for one without, a broker
    restarted a step after its kill."""
    assert metrics["settings"]["faults"] == [
        {"kind": "gamma_offset", "vehicle": 2, "offset": 0.001, "start": 10.0, "end": 20.0},
        {"kind": "broker_kill", "start": 4.0, "end": pytest.approx(4.1)},
    ]

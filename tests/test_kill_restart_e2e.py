"""A scheduled vehicle_kill is the fault itself, not a loss: under the default on_vehicle_loss = "abort" the run goes
on without the vehicle (to its restart, if the fault has an end), in both engines alike; the kill and the restart
are announced and recorded, and the summary's statistics while it is down are over the vehicles alive.
(An unscheduled death still aborts: tests/test_cosim_e2e.py.)

    vehicle 2 ---- vehicle 1 ---- vehicle 3        (paper graph; vehicle 3 killed at 8 s, restarted at 12 s)
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from supervisor.record.recorder import read_messages
from tests.conftest import shortened
from tests.procs import cpf, processes_with
from tests.test_faults_e2e import records

pytestmark = pytest.mark.e2e

ENGINES = ("zenoh", "inprocess")


def run(tmp_path: Path, text: str, fault: str, engine: str) -> tuple[str, str, Path]:
    """cpf run under the scenario's own on_vehicle_loss (the default: abort), a short transient so the summary has
    path-following errors to judge; returns stdout, stderr and the log."""
    scenario = tmp_path / "s.toml"
    scenario.write_text(text)
    out = tmp_path / f"{engine}.mcap"
    args = ["--engine", engine, "--fault", fault, "--set", "report.transient=2", "--out", str(out), "--quiet"]
    done = cpf("run", str(scenario), *args, "--metrics", str(tmp_path / f"{engine}.json"), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert processes_with(str(scenario)) == []
    return done.stdout, done.stderr, out


def steps_of(path: Path, vehicle: int) -> set[int]:
    return {m["k"] for topic, _, m in read_messages(path) if topic == f"cpf/vehicle/{vehicle}/state"}


def test_a_scheduled_kill_with_a_restart_runs_through_under_abort_in_both_engines(tmp_path, paper_text):
    text = shortened(paper_text, 20.0)
    assert "on_vehicle_loss" not in text  # the default, abort
    outputs = {e: run(tmp_path, text, "kind=vehicle_kill,vehicle=3,start=8,end=12", e) for e in ENGINES}
    for engine, (stdout, stderr, log) in outputs.items():
        # It glided on while its computer was down (vehicles.coast), slowing under its drag, instead of waiting
        # where it was: its first state after the restart is ahead of its last, and slower.
        before, after = state_at(log, 3, 79), state_at(log, 3, 120)
        assert math.dist(before["position"], after["position"]) > 1.0, engine
        assert math.hypot(*after["velocity"]) < math.hypot(*before["velocity"]), engine
        lines = stderr.splitlines()
        assert "cpf run: vehicle 3 killed at t = 8.0 s (scheduled vehicle_kill; restarted at t = 12.0 s)" in lines
        restarted = (
            "cpf run: vehicle 3 restarted at t = 12.0 s (scheduled vehicle_kill;"
            " it coasted without control since its state of t = 7.9 s)"
        )
        assert restarted in lines
        faults = [(m["kind"], m["phase"], m["t"]) for t, _, m in read_messages(log) if t == "cpf/run/fault"]
        assert faults == [("vehicle_kill", "start", 8.0), ("vehicle_kill", "end", 12.0)], engine
        steps = steps_of(log, 3)
        assert not steps & set(range(80, 120)) and {79, 120, 199} <= steps, engine
        # While it is down the summary speaks of the two vehicles alive: numbers, not nan.
        down = next(line for line in stdout.splitlines() if line.startswith("during vehicle_kill")).split()
        assert down[2] == "8-12" and down[-1] == "-", down  # vehicle 3's mean gamma_dot: it was down throughout
        assert all(math.isfinite(float(v)) for v in down[3:-1]), down  # max and end |gi-gj|, |p-pd|, two rates
        assert "path-following error after the transient (from t = 2 s): max" in stdout, stdout
        phase = json.loads((tmp_path / f"{engine}.json").read_text())["coordination"]["phases"][1]
        assert phase["max_coordination_error"] is not None and phase["max_path_error"] is not None
        assert phase["mean_gamma_dot"][2] is None and phase["mean_gamma_dot"][0] is not None
    assert records(outputs["zenoh"][2]) == records(outputs["inprocess"][2])


def test_a_scheduled_kill_without_restart_goes_on_without_the_vehicle_under_abort(tmp_path, paper_text):
    text = shortened(paper_text, 10.0)
    outputs = {e: run(tmp_path, text, "kind=vehicle_kill,vehicle=2,start=6", e) for e in ENGINES}
    for engine, (_, stderr, log) in outputs.items():
        assert "cpf run: vehicle 2 killed at t = 6.0 s (scheduled vehicle_kill; the run goes on without it)" in stderr
        assert max(steps_of(log, 2)) == 59 and max(steps_of(log, 1)) == 99, engine
    assert records(outputs["zenoh"][2]) == records(outputs["inprocess"][2])


def test_report_metrics_while_a_vehicle_is_down_are_over_the_vehicles_alive(tmp_path, paper_text):
    """metrics.json of `cpf report` on a run that ends with a vehicle down: numbers, and the tube judged."""
    _, _, log = run(tmp_path, shortened(paper_text, 10.0), "kind=vehicle_kill,vehicle=2,start=6", "inprocess")
    done = cpf("report", str(log), "--out", str(tmp_path / "report"), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    metrics = json.loads((tmp_path / "report" / "metrics.json").read_text())
    coordination, path = metrics["coordination"], metrics["path_following"]
    assert coordination["steady_state_error"] is not None
    assert all(p["max_coordination_error"] is not None for p in coordination["phases"])
    assert path["max_error_after_transient"] is not None and isinstance(path["inside_tube"], bool)


def state_at(path: Path, vehicle: int, k: int) -> dict:
    topic = f"cpf/vehicle/{vehicle}/state"
    return next(m for t, _, m in read_messages(path) if t == topic and m["k"] == k)

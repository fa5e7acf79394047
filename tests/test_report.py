"""Tests for supervisor.report: loading a recorded run into arrays, fault intervals, and the PNG figures."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from comms.messages import FAULT_KEY, GRAPH_KEY, META_KEY, state_key
from supervisor.recorder import Recorder
from supervisor.report import FaultInterval, RunData, load_run, write_figures

# --- a synthetic run --------------------------------------------------------------------------------------
# Helices like the paper's example (radii c_i, period T in gamma, climb d per unit gamma); gammas converge
# to each other and path-following errors decay, so the figures look like the real thing.

VEHICLES = (1, 2, 3)
RADII = {1: 20.0, 2: 15.0, 3: 25.0}
GAMMA0 = {1: 0.0, 2: 12.0, 3: -8.0}
PERIOD, CLIMB, PHASE = 400.0, 0.05, -3.0 * math.pi / 4.0
STEP, STEPS = 0.5, 400
EDGES = [[1, 2], [1, 3]]
FAULT: dict[str, Any] = {"kind": "slowdown", "start": 60.0, "end": 90.0, "vehicle": 1}
TUBE_RADIUS = 2.0


def desired(vehicle: int, gamma: float) -> list[float]:
    angle = 2.0 * math.pi * gamma / PERIOD + PHASE
    c = RADII[vehicle]
    return [c * math.cos(angle), c * math.sin(angle), CLIMB * gamma]


def gamma_of(vehicle: int, t: float) -> float:
    return t + GAMMA0[vehicle] * math.exp(-t / 20.0)


def state(vehicle: int, t: float) -> dict[str, Any]:
    gamma = gamma_of(vehicle, t)
    decay = math.exp(-t / 15.0)
    error = [5.0 * decay, -3.0 * decay, (vehicle - 2) * 4.0 * decay]
    pd = desired(vehicle, gamma)
    return {
        "t": t,
        "vehicle": vehicle,
        "gamma": gamma,
        "gamma_dot": 1.0 - GAMMA0[vehicle] / 20.0 * math.exp(-t / 20.0),
        "position": [p + e for p, e in zip(pd, error, strict=True)],
        "rotation": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        "velocity": [0.3 + 0.02 * vehicle * (1.0 - decay), 0.05 * decay * math.sin(t), -0.1 * decay],
        "angular_velocity": [0.0, 0.0, 0.01],
        "error": error,
        "tau": [10.0 * decay, 0.1, 0.2, 0.0],
        "correction": -0.1 * decay,
        "lyapunov": 0.5 * sum(e * e for e in error),
    }


def meta(faults: list[dict[str, Any]]) -> dict[str, Any]:
    return {
        "scenario_name": "synthetic",
        "scenario_file": "synthetic.toml",
        "scenario_toml": "",
        "seed": 7,
        "engine": "inprocess",
        "step": STEP,
        "duration": STEP * (STEPS - 1),
        "vehicles": list(VEHICLES),
        "edges": EDGES,
        "faults": faults,
        "tube_radius": TUBE_RADIUS,
        "versions": {"cpf-cosim": "test"},
    }


def fault_event(t: float, phase: str) -> dict[str, Any]:
    return {"t": t, "kind": FAULT["kind"], "phase": phase, "detail": {"vehicle": FAULT["vehicle"]}}


def write_run(path: Path, events: list[dict[str, Any]], meta_faults: list[dict[str, Any]]) -> Path:
    """Record meta, states of every vehicle at every step, the given fault events and one graph change."""
    with Recorder(path) as recorder:
        recorder.write(META_KEY, 0.0, meta(meta_faults))
        pending = sorted(events, key=lambda e: float(e["t"]))
        for k in range(STEPS):
            t = k * STEP
            while pending and float(pending[0]["t"]) <= t:
                recorder.write(FAULT_KEY, t, pending.pop(0))
            if k == 100:
                recorder.write(GRAPH_KEY, t, {"t": t, "edges": [[1, 2], [2, 3]]})
            for vehicle in VEHICLES:
                recorder.write(state_key(vehicle), t, state(vehicle, t))
    return path


@pytest.fixture(scope="module")
def run_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("run") / "run.mcap"
    return write_run(path, [fault_event(FAULT["start"], "start"), fault_event(FAULT["end"], "end")], [FAULT])


@pytest.fixture(scope="module")
def run(run_path: Path) -> RunData:
    return load_run(run_path)


# --- load_run ---------------------------------------------------------------------------------------------


def test_load_run_meta_and_graph(run: RunData) -> None:
    assert run.meta["scenario_name"] == "synthetic"
    assert run.meta["tube_radius"] == TUBE_RADIUS
    assert run.edges == [(1, 2), (1, 3)]
    assert run.graph_changes == [(50.0, [(1, 2), (2, 3)])]
    assert run.t_range == (0.0, STEP * (STEPS - 1))


def test_load_run_arrays(run: RunData) -> None:
    times = np.arange(STEPS) * STEP
    assert list(run.vehicles) == list(VEHICLES)
    for vehicle, series in run.vehicles.items():
        assert series.vehicle == vehicle
        for name in ("t", "gamma", "gamma_dot", "correction", "lyapunov"):
            assert getattr(series, name).shape == (STEPS,), name
        for name in ("position", "velocity", "error"):
            assert getattr(series, name).shape == (STEPS, 3), name
        assert series.tau.shape == (STEPS, 4)
        np.testing.assert_allclose(series.t, times)
        np.testing.assert_allclose(series.gamma, [gamma_of(vehicle, t) for t in times])
        expected = [desired(vehicle, gamma_of(vehicle, t)) for t in times]
        np.testing.assert_allclose(series.desired, expected, atol=1e-9)
        np.testing.assert_allclose(series.error_norm[0], math.sqrt(25.0 + 9.0 + ((vehicle - 2) * 4.0) ** 2))


def test_fault_interval_from_events(run: RunData) -> None:
    assert run.faults == [FaultInterval("slowdown", 60.0, 90.0, "slowdown (AUV 1)")]


def test_fault_without_end_runs_to_end_of_run(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run.mcap", [fault_event(100.0, "start")], [FAULT]))
    assert run.faults == [FaultInterval("slowdown", 100.0, STEP * (STEPS - 1), "slowdown (AUV 1)")]


def test_fault_events_pair_per_vehicle(tmp_path: Path) -> None:
    """Overlapping faults of one kind on two vehicles pair by vehicle; an orphan end runs from the start."""
    events = [
        {"t": 10.0, "kind": "slowdown", "phase": "start", "detail": {"vehicle": 1}},
        {"t": 20.0, "kind": "slowdown", "phase": "start", "detail": {"vehicle": 2}},
        {"t": 30.0, "kind": "slowdown", "phase": "end", "detail": {"vehicle": 2}},
        {"t": 40.0, "kind": "slowdown", "phase": "end", "detail": {"vehicle": 1}},
        {"t": 50.0, "kind": "blackout", "phase": "end", "detail": {}},
    ]
    run = load_run(write_run(tmp_path / "run.mcap", events, []))
    assert run.faults == [
        FaultInterval("blackout", 0.0, 50.0, "blackout"),
        FaultInterval("slowdown", 10.0, 40.0, "slowdown (AUV 1)"),
        FaultInterval("slowdown", 20.0, 30.0, "slowdown (AUV 2)"),
    ]


def test_no_fault_events_falls_back_to_meta(tmp_path: Path) -> None:
    planned = [FAULT, {"kind": "packet_loss", "start": 20.0, "end": None}]
    run = load_run(write_run(tmp_path / "run.mcap", [], planned))
    assert run.faults == [
        FaultInterval("packet_loss", 20.0, STEP * (STEPS - 1), "packet_loss"),
        FaultInterval("slowdown", 60.0, 90.0, "slowdown (AUV 1)"),
    ]


def test_no_faults_at_all(tmp_path: Path) -> None:
    assert load_run(write_run(tmp_path / "run.mcap", [], [])).faults == []


# --- write_figures ----------------------------------------------------------------------------------------

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
EXPECTED_FIGURES = [
    "fig3_trajectories.png",
    "fig4_path_following_errors.png",
    "fig5_coordination_errors.png",
    "fig6_velocities_auv1.png",
    "fig6_velocities_auv2.png",
    "fig6_velocities_auv3.png",
    "gamma_dot.png",
]


def check_pngs(paths: list[Path], out_dir: Path) -> None:
    assert [p.name for p in paths] == EXPECTED_FIGURES
    for path in paths:
        assert path.parent == out_dir
        data = path.read_bytes()
        assert data.startswith(PNG_SIGNATURE), path.name
        assert len(data) > 5_000, path.name


def test_write_figures(run: RunData, tmp_path: Path) -> None:
    out_dir = tmp_path / "figures"
    check_pngs(write_figures(run, out_dir), out_dir)


def test_write_figures_without_faults_or_tube(tmp_path: Path) -> None:
    """No faults and no tube radius: some legends are empty, which must not warn (warnings fail)."""
    run = load_run(write_run(tmp_path / "run.mcap", [], []))
    bare = RunData({k: v for k, v in run.meta.items() if k != "tube_radius"}, run.vehicles, [], run.edges)
    check_pngs(write_figures(bare, tmp_path), tmp_path)

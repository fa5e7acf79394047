"""Tests for supervisor.analysis.report: loading a recorded run into arrays, fault intervals, and the PNG figures."""

from __future__ import annotations

import io
import json
import math
import re
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import msgspec
import numpy as np
import pytest

from comms.records.events import logged_events
from comms.records.messages import COMMS_EVENT_KEY, COMMS_STATS_KEY, FAULT_KEY, GRAPH_KEY, META_KEY, state_key
from supervisor.analysis.metrics import STEADY_STATE_WINDOW, run_metrics
from supervisor.analysis.report import FaultInterval, RunData, load_run, write_figures, write_report
from supervisor.analysis.summary import summarize
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import RunResult, run_inprocess
from supervisor.engine.progress import Progress
from supervisor.errors import ScenarioError
from supervisor.record.recorder import Recorder, read_messages
from supervisor.record.recover import recover
from supervisor.tools.info import LogError
from tests.conftest import CONFIGS, shortened

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
        "k": round(t / STEP),
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
        "tx_seq": 0,
        "estimate_age": [[j, age_of(j, vehicle, t)] for j in NEIGHBOURS[vehicle]],
    }


# --- synthetic channel: each directed link sends every PACKET_PERIOD s; some packets are lost -----------------

LINKS = ((1, 2), (2, 1), (1, 3), (3, 1))
NEIGHBOURS = {1: (2, 3), 2: (1,), 3: (1,)}
PACKET_PERIOD, STATS_WINDOW = 5.0, 20.0


def age_of(neighbour: int, holder: int, t: float) -> float:
    return (t + neighbour + holder) % PACKET_PERIOD + 0.5


def delay_of(sender: int, seq: int) -> float:
    return 0.5 + 0.01 * seq + 0.1 * sender


def fate(sender: int, receiver: int, seq: int) -> str | None:
    """Why packet seq of a link is lost (None: delivered)."""
    if (seq + sender) % 4 == 3:
        return "loss"
    if receiver == 3 and seq % 7 == 6:
        return "collision"
    return None


def link_events(sender: int, receiver: int) -> list[dict[str, Any]]:
    events = []
    for seq in range(1, int(STEP * (STEPS - 1) / PACKET_PERIOD)):
        t = seq * PACKET_PERIOD - 0.5 * sender
        base = {"sender": sender, "receiver": receiver, "seq": seq, "delay": None, "reason": None}
        events.append({**base, "t": t, "kind": "sent"})
        reason = fate(sender, receiver, seq)
        if reason is None:
            delay = delay_of(sender, seq)
            events.append({**base, "t": t + delay, "kind": "delivered", "delay": delay})
        else:
            events.append({**base, "t": t + 0.2, "kind": "dropped", "reason": reason})
    return events


def comms_messages() -> list[tuple[float, str, dict[str, Any]]]:
    """(t, key, message) of every link event and stats snapshot of the synthetic run, in time order."""
    out = [(float(e["t"]), COMMS_EVENT_KEY, e) for link in LINKS for e in link_events(*link)]
    for k in range(1, int(STEP * (STEPS - 1) / STATS_WINDOW) + 1):
        t = k * STATS_WINDOW
        out.append((t, COMMS_STATS_KEY, {"t": t, "window": STATS_WINDOW, "lambda2": float(k % 3 != 0), "links": []}))
    return sorted(out, key=lambda m: m[0])


def meta(faults: list[dict[str, Any]]) -> dict[str, Any]:
    return {
        "scenario_name": "synthetic",
        "scenario_file": "synthetic.toml",
        "scenario_toml": "",
        "seed": 7,
        "scenario": {},
        "engine": "inprocess",
        "clock": "lockstep",
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


def write_run(path: Path, events: list[dict[str, Any]], meta_faults: list[dict[str, Any]], comms: bool = True) -> Path:
    """Record meta, states of every vehicle at every step, the given fault events, one graph change and (comms)
    the link events and stats snapshots."""
    with Recorder(path) as recorder:
        recorder.write(META_KEY, 0.0, meta(meta_faults))
        pending = sorted(events, key=lambda e: float(e["t"]))
        channel = comms_messages() if comms else []
        for k in range(STEPS):
            t = k * STEP
            while pending and float(pending[0]["t"]) <= t:
                recorder.write(FAULT_KEY, t, pending.pop(0))
            while channel and channel[0][0] <= t:
                recorder.write(channel[0][1], channel[0][0], channel.pop(0)[2])
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
    assert run.meta is not None and run.meta.scenario_name == "synthetic"
    assert run.meta.tube_radius == TUBE_RADIUS
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


# --- comms data ---------------------------------------------------------------------------------------------


def test_load_run_link_events(run: RunData) -> None:
    assert list(run.links) == sorted(LINKS)
    for (sender, receiver), link in run.links.items():
        expected = sorted(link_events(sender, receiver), key=lambda e: e["t"])
        assert (link.sender, link.receiver, link.name) == (sender, receiver, f"{sender}->{receiver}")
        np.testing.assert_allclose(link.t, [e["t"] for e in expected])
        assert list(link.kind) == [e["kind"] for e in expected]
        delivered = [float(e["delay"]) for e in expected if e["kind"] == "delivered"]
        np.testing.assert_allclose(link.delays, delivered)
        assert np.isnan(link.delay[link.kind != "delivered"]).all()
        causes = Counter(e.get("reason") for e in expected if e["kind"] == "dropped")
        assert link.dropped_by_cause() == dict(causes)
        assert link.times("sent").size == sum(e["kind"] == "sent" for e in expected)


def test_load_run_stats_and_estimate_ages(run: RunData) -> None:
    assert [s.t for s in run.stats] == [STATS_WINDOW * k for k in range(1, 10)]
    assert list(run.estimate_ages) == [(1, 2), (1, 3), (2, 1), (3, 1)]  # (neighbour, holder)
    for (neighbour, holder), ages in run.estimate_ages.items():
        assert neighbour in NEIGHBOURS[holder]
        np.testing.assert_allclose(ages.t, np.arange(STEPS) * STEP)
        np.testing.assert_allclose(ages.age, [age_of(neighbour, holder, t) for t in ages.t])


def test_link_fault_labels(tmp_path: Path) -> None:
    events = [
        {"t": 10.0, "kind": "link_down", "phase": "start", "detail": {"sender": 1, "receiver": 2, "both": True}},
        {"t": 12.0, "kind": "link_down", "phase": "start", "detail": {"sender": 3, "receiver": 1, "both": False}},
        {"t": 20.0, "kind": "link_down", "phase": "end", "detail": {"sender": 3, "receiver": 1, "both": False}},
        {"t": 30.0, "kind": "link_down", "phase": "end", "detail": {"sender": 1, "receiver": 2, "both": True}},
    ]
    assert load_run(write_run(tmp_path / "run.mcap", events, [], comms=False)).faults == [
        FaultInterval("link_down", 10.0, 30.0, "link_down (link 1<->2)"),
        FaultInterval("link_down", 12.0, 20.0, "link_down (link 3->1)"),
    ]


def test_not_a_log(tmp_path: Path) -> None:
    path = tmp_path / "notes.mcap"
    path.write_text("not an mcap file")
    with pytest.raises(LogError, match="not an MCAP file"):
        load_run(path)
    with pytest.raises(LogError, match="no such log file"):
        load_run(tmp_path / "missing.mcap")


# --- write_figures ----------------------------------------------------------------------------------------

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PAPER_FIGURES = [
    "fig3_trajectories.png",
    "fig4_path_following_errors.png",
    "fig5_coordination_errors.png",
    "fig6_velocities_auv1.png",
    "fig6_velocities_auv2.png",
    "fig6_velocities_auv3.png",
    "gamma_dot.png",
]
COMMS_FIGURES = ["comms_packets.png", "comms_delay_histogram.png", "comms_estimate_age.png"]
LAMBDA2_FIGURE = "comms_lambda2.png"


def check_pngs(paths: list[Path], out_dir: Path, names: list[str], min_bytes: int = 5_000) -> None:
    assert [p.name for p in paths] == names
    for path in paths:
        assert path.parent == out_dir
        data = path.read_bytes()
        assert data.startswith(PNG_SIGNATURE), path.name
        assert len(data) > min_bytes, path.name


def test_write_figures(run: RunData, tmp_path: Path) -> None:
    out_dir = tmp_path / "figures"
    paths = write_figures(run, out_dir)
    check_pngs(paths, out_dir, [*PAPER_FIGURES, *COMMS_FIGURES, LAMBDA2_FIGURE])
    check_pngs(paths[len(PAPER_FIGURES) :], out_dir, [*COMMS_FIGURES, LAMBDA2_FIGURE], min_bytes=10_000)


def test_write_figures_without_faults_or_tube(tmp_path: Path) -> None:
    """No faults, no tube radius, no channel: some legends are empty, which must not warn (warnings fail); no
    channel figure is drawn without its data (issue 30: a resim log's empty panels), no lambda_2 without stats."""
    run = load_run(write_run(tmp_path / "run.mcap", [], [], comms=False))
    assert not run.links and not run.stats
    assert run.meta is not None
    bare = RunData(msgspec.structs.replace(run.meta, tube_radius=math.nan), run.vehicles, [], run.edges)
    check_pngs(write_figures(bare, tmp_path), tmp_path, PAPER_FIGURES)


def test_synthetic_metrics_packets(run: RunData) -> None:
    packets = run_metrics(run)["packets"]
    for sender, receiver in LINKS:
        events = link_events(sender, receiver)
        kinds = Counter(e["kind"] for e in events)
        counts = packets["links"][f"{sender}->{receiver}"]
        assert (counts["sent"], counts["delivered"], counts["dropped"], counts["in_flight"]) == (
            kinds["sent"], kinds["delivered"], kinds["dropped"], 0,
        )  # fmt: skip
        assert counts["dropped_by_cause"] == dict(Counter(e.get("reason") for e in events if e["kind"] == "dropped"))
    total = packets["total"]
    assert total["sent"] == sum(c["sent"] for c in packets["links"].values())
    assert total["dropped_by_cause"].keys() == {"loss", "collision"}


# --- a real run: paper.toml, 80 s, lossy, its fault moved into the run and a link cut during it ---------------

DURATION = 80.0
FIRST_FAULT, LAST_FAULT_END = 45.0, 55.0
# Reached in each phase (the fleet starts 50 apart in gamma: with the correction bounded by each vehicle's thrust,
# the default, it takes about 35 s).
TOLERANCE = 5.0
OVERRIDES = [
    "comms.loss=0.2",
    f"faults.0.start={FIRST_FAULT}",
    f"faults.0.end={LAST_FAULT_END}",
    f"report.coordination_tolerance={TOLERANCE}",
]
EXTRA_FAULTS = ["kind=link_down,sender=1,receiver=2,start=48,end=52"]


@dataclass(frozen=True)
class RealRun:
    log: Path
    result: RunResult
    run: RunData
    out: Path
    paths: list[Path]
    metrics: dict[str, Any]


@pytest.fixture(scope="module")
def real(tmp_path_factory: pytest.TempPathFactory) -> RealRun:
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    scenario = parse_scenario(text, "paper60.toml", OVERRIDES, EXTRA_FAULTS)
    log = tmp_path_factory.mktemp("real") / "run.mcap"
    result = run_inprocess(scenario, "paper60.toml", text, log, 0, Progress(DURATION, io.StringIO(), enabled=False))
    out = log.parent / "report"
    paths = write_report(log, out)
    metrics = json.loads((out / "metrics.json").read_text(), parse_constant=_no_constant)
    return RealRun(log, result, load_run(log), out, paths, metrics)


def _no_constant(name: str) -> None:
    raise AssertionError(f"metrics.json holds {name}: not strict JSON")


@pytest.fixture(scope="module")
def logged(real: RealRun) -> list[tuple[str, int, dict[str, Any]]]:
    """The log as supervisor.record.recorder reads it: independent of the report's reader."""
    return read_messages(real.log)


def test_real_report_files(real: RealRun) -> None:
    names = [*PAPER_FIGURES, *COMMS_FIGURES, LAMBDA2_FIGURE]
    check_pngs(real.paths[:-1], real.out, names)
    check_pngs(real.paths[len(PAPER_FIGURES) : -1], real.out, [*COMMS_FIGURES, LAMBDA2_FIGURE], min_bytes=10_000)
    assert real.paths[-1] == real.out / "metrics.json"


def test_real_packets_equal_the_logged_events(real: RealRun, logged: list[tuple[str, int, dict[str, Any]]]) -> None:
    events = [event for topic, _, m in logged for event in logged_events(topic, m)]
    books: dict[str, Counter[str]] = {}
    for e in events:
        book = books.setdefault(f"{e['sender']}->{e['receiver']}", Counter())
        book[e["kind"]] += 1
        if e["kind"] == "dropped":
            book[f"cause:{e['reason']}"] += 1
    packets = real.metrics["packets"]
    assert set(packets["links"]) == set(books) == {"1->2", "1->3", "2->1", "3->1"}
    for name, book in books.items():
        counts = packets["links"][name]
        assert (counts["sent"], counts["delivered"], counts["dropped"]) == (
            book["sent"], book["delivered"], book["dropped"],
        ), name  # fmt: skip
        causes = {k.removeprefix("cause:"): n for k, n in book.items() if k.startswith("cause:")}
        assert counts["dropped_by_cause"] == causes, name
    assert packets["links"]["1->2"]["dropped_by_cause"]["link_down"] > 0  # the cut link
    assert packets["links"]["1->2"]["dropped_by_cause"]["loss"] > 0
    total = packets["total"]
    assert {k: total[k] for k in ("sent", "delivered", "dropped")} == real.result.link_counts  # the run's books
    assert total["sent"] == total["delivered"] + total["dropped"] and total["in_flight"] == 0


def coordination_series(logged: list[tuple[str, int, dict[str, Any]]]) -> tuple[np.ndarray, np.ndarray]:
    """(t, max_ij |gamma_i - gamma_j|) from the logged states, computed here."""
    gammas: dict[int, dict[int, float]] = {}
    times: dict[int, float] = {}
    for topic, _, m in logged:
        if re.fullmatch(r"cpf/vehicle/\d+/state", topic):
            gammas.setdefault(m["k"], {})[m["vehicle"]] = m["gamma"]
            times[m["k"]] = m["t"]
    steps = sorted(gammas)
    error = [max(gammas[k].values()) - min(gammas[k].values()) for k in steps]
    return np.array([times[k] for k in steps]), np.array(error)


def check_settled(t: np.ndarray, error: np.ndarray, tolerance: float, settled: float | None) -> None:
    """settled is when error drops below tolerance for good within (t, error); None if it never does."""
    if settled is None:
        assert error[-1] >= tolerance
        return
    after = t >= settled - 1e-9
    assert (error[after] < tolerance).all()
    before = ~after
    assert not before.any() or error[before][-1] >= tolerance


def test_real_convergence_times(real: RealRun, logged: list[tuple[str, int, dict[str, Any]]]) -> None:
    t, error = coordination_series(logged)
    coord = real.metrics["coordination"]
    assert coord["tolerance"] == TOLERANCE
    first, last = t < FIRST_FAULT, t >= LAST_FAULT_END
    assert coord["convergence_time"] is not None and 0.0 < coord["convergence_time"] < FIRST_FAULT
    check_settled(t[first], error[first], TOLERANCE, coord["convergence_time"])
    check_settled(t[last], error[last], TOLERANCE, coord["reconvergence_time"])
    # the same as the engine's own summary of the run
    summary = summarize(real.result.series, DURATION, [("speed_cap", 45.0, 55.0), ("link_down", 48.0, 52.0)],
                        50.0, 1.2, TOLERANCE)  # fmt: skip
    assert coord["convergence_time"] == pytest.approx(summary.sync_time)
    assert coord["reconvergence_time"] == pytest.approx(summary.resync_time)


def test_real_convergence_with_a_tighter_tolerance(
    real: RealRun, logged: list[tuple[str, int, dict[str, Any]]]
) -> None:
    """Tolerance 1: never within the first phase, reached again well after the fault."""
    assert real.run.meta is not None
    scenario = json.loads(json.dumps(real.run.meta.scenario))
    scenario["report"]["coordination_tolerance"] = 1.0
    meta = msgspec.structs.replace(real.run.meta, scenario=scenario)
    coord = run_metrics(replace(real.run, meta=meta))["coordination"]
    t, error = coordination_series(logged)
    assert coord["convergence_time"] is None
    assert coord["reconvergence_time"] is not None and coord["reconvergence_time"] > LAST_FAULT_END + 1.0
    last = t >= LAST_FAULT_END
    check_settled(t[last], error[last], 1.0, coord["reconvergence_time"])


def test_real_phases_and_steady_state(real: RealRun, logged: list[tuple[str, int, dict[str, Any]]]) -> None:
    t, error = coordination_series(logged)
    coord = real.metrics["coordination"]
    bounds = [(p["start"], p["end"]) for p in coord["phases"]]
    assert bounds == [(0.0, 45.0), (45.0, 48.0), (48.0, 52.0), (52.0, 55.0), (55.0, DURATION)]
    assert [p["name"] for p in coord["phases"]][2] == "during link_down+speed_cap"
    for phase in coord["phases"]:
        inside = (t >= phase["start"]) & (t < phase["end"])
        assert phase["max_coordination_error"] == pytest.approx(error[inside].max())
        assert phase["final_coordination_error"] == pytest.approx(error[inside][-1])
    start = max(t[-1] - STEADY_STATE_WINDOW, 50.0)  # after report.transient
    assert coord["steady_state_error"] == pytest.approx(error[t >= start].max())
    assert coord["steady_state_window"] == pytest.approx([start, t[-1]])


def test_real_path_following_and_rates(real: RealRun, logged: list[tuple[str, int, dict[str, Any]]]) -> None:
    states = [m for topic, _, m in logged if re.fullmatch(r"cpf/vehicle/\d+/state", topic)]
    settled = [float(np.linalg.norm(m["error"])) for m in states if m["t"] >= 50.0]  # report.transient
    follow = real.metrics["path_following"]
    assert follow["max_error_after_transient"] == pytest.approx(max(settled))
    assert follow["tube_radius"] == pytest.approx(1.2)
    assert follow["inside_tube"] == (max(settled) <= 1.2)
    last = {m["vehicle"]: m["gamma_dot"] for m in states}  # the last state of each vehicle wins
    assert real.metrics["gamma_dot_end"] == {str(v): pytest.approx(g) for v, g in last.items()}


def test_real_ages_and_lambda2(real: RealRun, logged: list[tuple[str, int, dict[str, Any]]]) -> None:
    ages = real.metrics["estimate_age"]
    for (sender, receiver), (total, count, largest) in real.result.estimate_ages.items():
        assert ages[f"{sender}->{receiver}"]["mean"] == pytest.approx(total / count)
        assert ages[f"{sender}->{receiver}"]["max"] == pytest.approx(largest)
    lambdas = [m["lambda2"] for topic, _, m in logged if topic == COMMS_STATS_KEY]
    assert real.metrics["lambda2"]["windows"] == len(lambdas) > 0
    assert real.metrics["lambda2"]["min"] == pytest.approx(min(lambdas))


def test_truncated_log_is_refused_and_its_recovery_loads_what_it_holds(real: RealRun, tmp_path: Path) -> None:
    """A log whose writer died (no summary, a chunk cut short) is refused, pointing to `cpf recover`; the
    recovered log holds the start of the run."""
    data = real.log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 6 // 10])
    with pytest.raises(LogError, match=r"cut\.mcap: cut short or damaged .*`cpf recover .*cut\.mcap`"):
        load_run(cut)
    assert recover(cut, tmp_path / "fixed.mcap").messages
    recovered = load_run(tmp_path / "fixed.mcap")
    assert recovered.meta == real.run.meta
    for vehicle, series in recovered.vehicles.items():
        assert 0 < series.t.size < real.run.vehicles[vehicle].t.size
        np.testing.assert_array_equal(series.gamma, real.run.vehicles[vehicle].gamma[: series.t.size])


def test_a_meta_that_does_not_read_is_one_line_naming_its_field(tmp_path: Path) -> None:
    """The meta is read through its record (RunMeta): a step of "fast" was taken in raw and ended the report in a
    ValueError traceback from float("fast")."""
    path = tmp_path / "run.mcap"
    with Recorder(path) as recorder:
        recorder.write(META_KEY, 0.0, {**meta([]), "step": "fast"})
        for vehicle in VEHICLES:
            recorder.write(state_key(vehicle), 0.0, state(vehicle, 0.0))
    with pytest.raises(ScenarioError, match=r"run\.mcap: cpf/run/meta: .*'step'") as caught:
        run_metrics(load_run(path))
    assert len(str(caught.value).splitlines()) == 1


def test_a_stats_snapshot_that_does_not_read_is_named_and_skipped(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Snapshots are read through their record (CommsStats): one without its window ended the report in a KeyError
    traceback from the lambda_2 metrics; it is now named and left out (issue 31), the rest of the run reported."""
    path = tmp_path / "run.mcap"
    with Recorder(path) as recorder:
        recorder.write(META_KEY, 0.0, meta([]))
        for vehicle in VEHICLES:
            recorder.write(state_key(vehicle), 0.0, state(vehicle, 0.0))
        recorder.write(COMMS_STATS_KEY, 10.0, {"t": 10.0, "lambda2": 1.0, "links": []})
    run = load_run(path)
    assert run.stats == [] and sorted(run.vehicles) == list(VEHICLES)
    assert "cpf/comms/stats" in caplog.text and "'window'" in caplog.text
    run_metrics(run)


def test_a_record_the_report_cannot_use_is_named_and_skipped(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """A NaN gamma an older cpf logged as null refused the whole log ("field 'gamma' has type NoneType", issue 31):
    the report names the record and goes on without it."""
    path = tmp_path / "run.mcap"
    with Recorder(path) as recorder:
        recorder.write(META_KEY, 0.0, meta([]))
        for k in range(STEPS):
            for vehicle in VEHICLES:
                message = state(vehicle, k * STEP)
                recorder.write(state_key(vehicle), k * STEP, {**message, "gamma": None} if k == 7 else message)
    run = load_run(path)
    assert [run.vehicles[v].t.size for v in VEHICLES] == [STEPS - 1] * 3
    said = [r.getMessage() for r in caplog.records]
    assert any("cpf/vehicle/2/state" in line and "'gamma'" in line for line in said), said
    assert any("3 records skipped" in line for line in said), said


def test_the_runs_path_error_is_the_reports_to_the_bit(real: RealRun) -> None:
    """The summary's (and a sweep's) |p - p_d| and the report's, read from the log, are one computation
    (numerics.linalg.norm3 / row_norms): equal to the bit, not within a tolerance. numpy's vector norm (BLAS's dot)
    differed from the report's elementwise one in the last bit of ~11 % of the steps on a CPU with FMA."""
    series = real.result.series
    for column, vid in enumerate(series.vehicle_ids):
        logged = real.run.vehicles[vid]
        assert real.run.meta is not None
        steps = np.rint(logged.t / real.run.meta.step).astype(int)
        assert len(steps) > 100
        assert np.array_equal(series.path_error[steps, column], logged.error_norm), vid

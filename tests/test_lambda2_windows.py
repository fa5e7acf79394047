"""The delivered graph's lambda_2 when vehicles transmit less often than every stats window.

A pair is in the delivered graph of a window if it delivered within the last `horizon` s: the stats window, or 1.5
transmit intervals (the period held to the TDMA slot, or the event policy's heartbeat; with TDMA a frame at least,
whatever the policy) if that is longer. Six AUVs
on a line graph, TDMA with 4 s slots (a 24 s frame) and a 10 s stats window: every link delivers every frame, so
once every pair has heard from one of its two every window is connected.

    1 - 2 - 3 - 4 - 5 - 6        (graph; each transmits once per 24 s frame)
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from comms.broker.stats import LinkStats, clamp_lambda2
from comms.records.graph import algebraic_connectivity, laplacian
from comms.records.records import LinkEvent
from comms.records.reports import CommsStats
from supervisor.analysis.comms_summary import comms_summary, format_comms
from supervisor.analysis.metrics import run_metrics
from supervisor.analysis.report import RunData
from supervisor.analysis.report_comms import fig_lambda2
from supervisor.config.fleet import delivered_graph_horizon, transmit_interval
from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.recorder import read_messages
from tests.conftest import run_meta

PATH_GRAPH_6 = 2 * (1 - math.cos(math.pi / 6))  # lambda_2 of the path graph on six vertices


def tdma_fleet(transmit: str = "period = 1.0", slot: float = 4.0, duration: float = 100.0, n: int = 6) -> str:
    edges = [[i, i + 1] for i in range(1, n)]
    text = f'[scenario]\nname = "tdma{n}"\nduration = {duration}\nstep = 0.1\n\n[graph]\nedges = {edges}\n'
    for i in range(1, n + 1):
        text += f"""
[[vehicles]]
id = {i}
position = [-2.0, {20.0 * i - 1.0}, -10.0]
path = {{ type = "line", start = [0.0, {20.0 * i}, -10.0], velocity = [1.0, 0.0, 0.0] }}
"""
    text += f"\n[comms]\nstats_window = 10.0\n\n[comms.transmit]\n{transmit}\n"
    return text + (f"\n[comms.tdma]\nslot = {slot}\n" if slot else "")


def scenario(text: str) -> Scenario:
    return parse_scenario(text, "tdma.toml")


@pytest.mark.parametrize(
    ("transmit", "slot", "interval", "horizon"),
    [
        ("period = 1.0", 4.0, 24.0, 36.0),  # the wish waits for the vehicle's slot: once a frame
        ("period = 30.0", 4.0, 48.0, 72.0),  # due 30 s after a slot: the slot two frames on
        ("period = 24.0", 4.0, 24.0, 36.0),
        ('policy = "event"\nthreshold = 0.1\nheartbeat = 12.0', 2.0, 12.0, 18.0),
        ("period = 1.0", 0.0, 1.0, 10.0),  # no TDMA, a packet a second: the window says it all
        ("", 0.0, 0.1, 10.0),  # every step
        # may rightly stay quiet: no interval to expect, but no vehicle sends more often than once a frame (24 s)
        ('policy = "event"\nthreshold = 0.1', 4.0, None, 36.0),
        ('policy = "event"\nthreshold = 0.1', 1.0, None, 10.0),  # a 6 s frame: 1.5 of them within the window
        ('policy = "event"\nthreshold = 0.1', 0.0, None, 10.0),  # no TDMA: every step at most
        ("period = 1.0", 1.0, 6.0, 10.0),
    ],
)
def test_the_horizon_covers_the_longest_interval_a_schedule_leaves(
    transmit: str, slot: float, interval: float | None, horizon: float
) -> None:
    sc = scenario(tdma_fleet(transmit, slot))
    assert transmit_interval(sc) == (None if interval is None else pytest.approx(interval))
    assert delivered_graph_horizon(sc) == pytest.approx(horizon)


@pytest.mark.parametrize(
    "transmit",
    [
        "period = 1.0",
        # Event-triggered without a heartbeat, so eager it sends at every slot: its windows read disconnected (10 s
        # of horizon, a 24 s frame) though every link delivered every frame.
        'policy = "event"\nthreshold = 1e-9',
    ],
)
def test_every_window_is_connected_when_every_link_delivers_every_tdma_frame(tmp_path: Path, transmit: str) -> None:
    sc = scenario(tdma_fleet(transmit))
    quiet = Progress(sc.scenario.duration, enabled=False)
    result = run_inprocess(sc, "tdma.toml", "", tmp_path / "run.mcap", 0, quiet)
    assert result.link_stats is not None
    assert all(link["delivered"] >= 4 for link in result.link_stats["links"])  # every 24 s frame of 100 s
    history = [(float(h["t"]), float(h["lambda2"])) for h in result.stats_history]
    assert len(history) == 10
    # Slots start at 0, 4, ..., 20 s: by 20 s each pair has heard one of its two (5 -> 6 at 16 s), and from then
    # on every window holds every link. At 10 s only 1, 2 and 3 had spoken: 0, not -1e-17.
    assert history[0] == (10.0, 0.0)
    assert [round(v, 9) for _, v in history[1:]] == [round(PATH_GRAPH_6, 9)] * 9
    line = format_comms(comms_summary(result.link_stats, result.stats_history, result.estimate_ages)).splitlines()[-1]
    assert line == (
        "delivered-graph lambda_2 over 10 windows of 10 s (pairs that delivered in the last 36 s, 1.5 transmit "
        f"intervals): min 0.000, mean {0.9 * PATH_GRAPH_6:.3f} (0 = disconnected)"
    )


def test_a_single_lost_packet_still_shows() -> None:
    """Deliveries every 24 s on 1 -> 2 with one of them lost: the horizon (36 s) runs out before the next."""
    stats = LinkStats([1, 2], window=10.0, horizon=36.0)
    arrivals = [4.0, 28.0, 76.0]  # the one of 52 s lost
    stats.add([LinkEvent(t, 1, 2, k, "delivered", delay=0.0) for k, t in enumerate(arrivals)])
    assert [stats.delivered_connectivity(t) for t in (30.0, 60.0, 70.0, 80.0, 100.0)] == [2.0, 2.0, 0.0, 2.0, 2.0]


def test_a_disconnected_graph_has_lambda2_zero_never_a_rounding_error() -> None:
    tiny = algebraic_connectivity(laplacian(5, {(0, 1), (2, 3), (3, 4), (2, 4)}))
    assert abs(tiny) < 1e-12  # what eigvalsh says: +-1e-17 or so
    assert clamp_lambda2(tiny) == 0.0 and clamp_lambda2(-3e-17) == 0.0 and clamp_lambda2(8e-18) == 0.0
    assert clamp_lambda2(4.0 / 1000**2) == 4.0 / 1000**2  # the smallest of a connected graph of 1000 vertices


def test_an_older_logs_rounding_errors_print_as_zero() -> None:
    final = {"t": 30.0, "window": 10.0, "lambda2": -2e-17, "links": []}
    history = [{"t": 10.0, "lambda2": -2e-17}, {"t": 20.0, "lambda2": 8e-18}, {"t": 30.0, "lambda2": 1.0}]
    text = format_comms(comms_summary(final, history, {}))
    assert "-0.000" not in text
    assert text.splitlines()[-1] == (
        "delivered-graph lambda_2 over 3 windows of 10 s (pairs that delivered in the window): min 0.000, mean 0.333 "
        "(0 = disconnected)"
    )
    run = RunData(
        run_meta(vehicles=(1, 2)), {}, [], [(1, 2)], stats=[CommsStats.from_message({**final, **h}) for h in history]
    )
    lam = run_metrics(run)["lambda2"]
    assert (lam["min"], lam["disconnected_windows"], lam["horizon"]) == (0.0, 2, 10.0)
    title = fig_lambda2(run).axes[0].get_title()
    assert "min 0, mean 0.333, 2 disconnected" in title and "e-1" not in title


def test_the_lambda2_figure_says_over_what_the_graph_is_taken() -> None:
    stats = [{"t": 10.0 * k, "window": 10.0, "horizon": 36.0, "lambda2": 0.268, "links": []} for k in range(1, 4)]
    run = RunData(
        run_meta(vehicles=(1, 2, 3)), {}, [], [(1, 2), (2, 3)], stats=[CommsStats.from_message(s) for s in stats]
    )
    title = fig_lambda2(run).axes[0].get_title()
    assert "per 10 s window (pairs that delivered in the last 36 s)" in title
    assert np.isclose(run_metrics(run)["lambda2"]["horizon"], 36.0)


@pytest.mark.parametrize("restart", [35.0, 30.0])
def test_lambda2_is_taken_over_the_vehicles_alive(tmp_path: Path, restart: float) -> None:
    """Vehicle 4 at the end of the line 1 - 2 - 3 - 4 is killed from 12 s to 35 s: the survivors 1 - 2 - 3 still hear
    each other, so the windows ending at 20 and 30 s are connected (the path on three vertices: lambda_2 = 1), in the
    supervisor's books and in the broker's snapshots alike; counting the dead vehicle said 'disconnected'. Restarted
    at 30 s, the window's end, it is still out of that window: alive at its last step only, it could not deliver."""
    kill = f'\n[[faults]]\nkind = "vehicle_kill"\nvehicle = 4\nstart = 12.0\nend = {restart}\n'
    sc = scenario(tdma_fleet(slot=0.0, duration=40.0, n=4) + kill)
    quiet = Progress(sc.scenario.duration, enabled=False)
    result = run_inprocess(sc, "line4.toml", "", tmp_path / "run.mcap", 0, quiet, scene=False)
    history = {float(h["t"]): float(h["lambda2"]) for h in result.stats_history}
    assert history[20.0] == pytest.approx(1.0) and history[30.0] == pytest.approx(1.0)
    assert history[10.0] == pytest.approx(2 * (1 - math.cos(math.pi / 4)))  # before the kill: the path on four
    snapshots = {
        m["t"]: m["lambda2"] for topic, _, m in read_messages(tmp_path / "run.mcap") if topic.endswith("stats")
    }
    assert snapshots[20.0] == pytest.approx(1.0) and snapshots[30.0] == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("period", "slot"), [(1.0, 4.0), (30.0, 4.0), (24.0, 4.0), (24.1, 4.0), (23.9, 4.0), (0.0, 4.0), (7.0, 0.0)]
)
def test_the_interval_held_to_tdma_frames_is_the_one_the_fleet_keeps(
    tmp_path: Path, period: float, slot: float
) -> None:
    """transmit_interval and the stability analysis's period (links.timing) are links.held_to_frames: the gaps a
    vehicle's transmissions leave in a run, every one of them after its first."""
    from supervisor.config.links import timing

    sc = scenario(tdma_fleet(f"period = {period}" if period else "", slot, duration=150.0, n=3))
    quiet = Progress(sc.scenario.duration, enabled=False)
    run_inprocess(sc, "tdma.toml", "", tmp_path / "run.mcap", 0, quiet)
    sent: dict[str, list[float]] = {}
    for topic, _, message in read_messages(tmp_path / "run.mcap"):
        if topic.endswith("/tx"):
            sent.setdefault(topic, []).append(float(message["t"]))
    expected = transmit_interval(sc)
    assert expected is not None
    assert timing(sc)[0] == pytest.approx(expected)
    assert len(sent) == 3
    for times in sent.values():
        assert np.allclose(np.diff(times), expected, atol=1e-6), (times[:5], expected)

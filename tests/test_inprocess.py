"""The single-process engine on the repository's scenarios: the paper's acceptance numbers, and determinism."""

from __future__ import annotations

import io
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from supervisor.analysis.summary import Summary, summarize
from supervisor.config.derived import intervals
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import RunResult, run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, link_events, shortened


def run_text(text: str, out: Path) -> tuple[RunResult, Summary]:
    scenario = parse_scenario(text, "test.toml")
    quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
    result = run_inprocess(scenario, "test.toml", text, out, scenario.scenario.seed, quiet)
    faults = intervals(scenario)
    tube = abs(scenario.path_following.delta) + scenario.report.tube_margin
    rep = scenario.report
    summary = summarize(result.series, scenario.scenario.duration, faults, rep.transient, tube, 0.01)
    return result, summary


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory) -> tuple[RunResult, Summary, Path]:
    out = tmp_path_factory.mktemp("paper") / "paper.mcap"
    result, summary = run_text((CONFIGS / "paper.toml").read_text(), out)
    return result, summary, out


def test_paper_coordination_errors_meet_the_acceptance_numbers(paper_run):
    _, summary, _ = paper_run
    before, during, after = summary.phases
    assert (before.name, during.name, after.name) == ("before faults", "during speed_cap", "after faults")
    assert summary.sync_time is not None and summary.sync_time < 150.0
    assert before.final_coordination_error < 0.01
    assert 0.5 < during.max_coordination_error < 10.0  # the fault shows, and stays bounded
    assert summary.resync_time is not None and summary.resync_time < 350.0
    assert after.final_coordination_error < 1e-3


def test_paper_path_following_stays_in_the_tube_and_speeds_reach_v_r(paper_run):
    result, summary, _ = paper_run
    assert summary.max_path_error_after_transient <= summary.tube_radius
    series = result.series
    np.testing.assert_allclose(series.gamma_dot[-1], 1.0, atol=1e-3)
    during = (series.t >= 160) & (series.t < 250)
    np.testing.assert_allclose(series.gamma_dot[during, 0], 0.5, atol=1e-9)  # AUV 1 held at the cap
    assert np.all(series.gamma_dot[during, 1:] < 0.75)  # and its neighbours slowed down to wait for it


def test_paper_log_holds_every_step_of_every_vehicle_and_the_fault(paper_run):
    result, _, out = paper_run
    messages = read_messages(out)
    topics = [topic for topic, _, _ in messages]
    for vid in (1, 2, 3):
        assert topics.count(f"cpf/vehicle/{vid}/state") == 4000
    faults = [m for topic, _, m in messages if topic == "cpf/run/fault"]
    assert [(f["phase"], f["t"]) for f in faults] == [("start", 150.0), ("end", 250.0)]
    assert faults[0]["detail"]["vehicle"] == 1
    scene = sum(topic.startswith("foxglove/") for topic in topics)
    assert result.messages == len(messages) - scene and result.scene_messages == scene > 0


def test_same_scenario_twice_gives_identical_streams(tmp_path, paper_text):
    text = shortened(paper_text, 30.0)
    run_text(text, tmp_path / "a.mcap")
    run_text(text, tmp_path / "b.mcap")
    a = [(t, m) for topic, t, m in read_messages(tmp_path / "a.mcap") if topic.endswith("/state")]
    b = [(t, m) for topic, t, m in read_messages(tmp_path / "b.mcap") if topic.endswith("/state")]
    assert len(a) == 900 and a == b


def test_literal_law_runs_the_fleet_at_half_the_reference_speed(tmp_path, paper_text):
    # The bound on the correction (on by default) would cut the literal law's steady correction -k2 gamma_dot.
    literal = paper_text.replace('law = "corrected"', 'law = "literal"') + "\n[saturation]\ncorrection = 'none'\n"
    text = shortened(literal, 140.0)
    result, _ = run_text(text, tmp_path / "literal.mcap")
    # The coordination subsystem alone settles at k_zeta v_r / (k_zeta + K2) = 0.5; in the full loop the target
    # runs slower than the controller's feed-forward v_r, so the path-following term sigma' R' p_d^gamma adds ~0.02.
    final = result.series.gamma_dot[-1]
    assert np.ptp(final) < 1e-3
    np.testing.assert_allclose(final, 0.5, atol=0.03)


@pytest.mark.parametrize("actuators", ["ideal", "preset"])
def test_inline_formation_converges_from_scattered_starts(tmp_path, actuators):
    """The REMUS 100s of inline5 converge, in their tube, with ideal inputs (backstepping) and on their own fins
    (line_of_sight; with the fleet's v_d fed forward instead of its path point's gamma_dot it ended at 0.16)."""
    text = (
        (CONFIGS / "inline5.toml")
        .read_text()
        .replace("[path_following]", f'actuators = "{actuators}"\n\n[path_following]')
    )
    result, summary = run_text(text, tmp_path / "inline.mcap")
    assert result.series.gamma.shape[1] == 5
    assert summary.phases[0].max_coordination_error > 20.0  # they really start scattered
    assert summary.phases[0].final_coordination_error < 0.01
    assert summary.max_path_error_after_transient <= summary.tube_radius


def test_paper_scenario_converges_with_20_percent_loss_and_one_second_airtime(tmp_path, paper_text):
    lossy = paper_text.replace(
        "[[faults]]",
        "[comms]\nloss = 0.2\npacket_bytes = 32\nbitrate = 256.0\n\n[comms.transmit]\nperiod = 1.0\n\n[[faults]]",
        1,
    )
    result, summary = run_text(lossy, tmp_path / "lossy.mcap")
    counts = result.link_counts
    assert counts["sent"] == 1600 and counts["sent"] == counts["delivered"] + counts["dropped"]
    assert 0.15 < counts["dropped"] / counts["sent"] < 0.25
    assert summary.sync_time is not None and summary.sync_time < 150.0
    assert summary.phases[1].max_coordination_error < 10.0
    assert summary.resync_time is not None and summary.resync_time < 350.0


def steady_error(result: RunResult, start: float, end: float) -> float:
    """max_{i,j} |gamma_i - gamma_j| over [start, end)."""
    series = result.series
    window = (series.t >= start) & (series.t < end)
    return float(np.ptp(series.gamma[window], axis=1).max())


def transmissions(path: Path) -> int:
    return sum(1 for topic, _, _ in read_messages(path) if topic.endswith("/tx"))


def test_event_triggered_policy_matches_periodic_with_far_fewer_packets(tmp_path, paper_text):
    """Periodic every 1 s against event-triggered (h = 0.01, at most one message a second): the coordination
    errors stay within 0.01 of the periodic ones in every phase, with at least 45 % fewer packets (measured: 618 of
    1200 with the reference-speed predictor, whose prediction a vehicle leaves whenever its rate is not v_r, as in
    the speed_cap fault; 269 with first_order)."""
    periodic_text = paper_text.replace("[[faults]]", "[comms.transmit]\nperiod = 1.0\n\n[[faults]]", 1)
    event_text = paper_text.replace(
        "[[faults]]", "[comms.transmit]\npolicy = 'event'\nthreshold = 0.01\nmin_interval = 1.0\n\n[[faults]]", 1
    )
    periodic, p_summary = run_text(periodic_text, tmp_path / "periodic.mcap")
    event, e_summary = run_text(event_text, tmp_path / "event.mcap")
    sent_periodic, sent_event = transmissions(tmp_path / "periodic.mcap"), transmissions(tmp_path / "event.mcap")
    assert sent_periodic == 1200
    assert sent_event <= 0.55 * sent_periodic
    for p_phase, e_phase in zip(p_summary.phases, e_summary.phases, strict=True):
        assert abs(e_phase.max_coordination_error - p_phase.max_coordination_error) <= 0.01
    for start, end in ((120.0, 150.0), (200.0, 250.0), (320.0, 400.0)):
        assert steady_error(event, start, end) <= steady_error(periodic, start, end) + 0.01
    assert e_summary.sync_time is not None and e_summary.sync_time < 150.0
    assert e_summary.resync_time is not None and e_summary.resync_time < 350.0


def acoustic_text(tdma: bool) -> str:
    text = (CONFIGS / "paper_acoustic.toml").read_text()
    return text if tdma else text.replace("[comms.tdma]\nslot = 4.0", "")


def test_every_link_balances_with_every_cause_on_a_crowded_channel(tmp_path):
    """Random access with 3.2 s packets: losses of every kind; the event stream, the link statistics and the
    books all agree, cause by cause."""
    out = tmp_path / "crowded.mcap"
    run_text(acoustic_text(tdma=False), out)
    events: dict[tuple[int, int], Counter[str]] = {}
    final = None
    logged = read_messages(out)
    for m in link_events(logged):
        events.setdefault((m["sender"], m["receiver"]), Counter())[m.get("reason") or m["kind"]] += 1
    for topic, _, m in logged:
        if topic == "cpf/comms/stats":
            final = m
    assert final is not None
    causes = Counter[str]()
    for link in final["links"]:
        counted = events[(link["sender"], link["receiver"])]
        assert counted["sent"] == link["sent"] == link["delivered"] + sum(link["dropped"].values())
        assert counted["delivered"] == link["delivered"]
        assert {cause: counted[cause] for cause in link["dropped"]} == link["dropped"]
        causes.update(link["dropped"])
    assert {"half_duplex", "collision", "burst", "end_of_run"} <= set(causes)


def test_acoustic_paper_scenario_on_tdma_keeps_formation(tmp_path):
    """TDMA's guarantees (no collision, no half-duplex loss, at most one packet per vehicle per 12 s frame), the
    tube, and a formation that holds. With one message per 12 s and bursty loss, coordination errors settle to a
    few hundredths to about one unit of gamma depending on the seed (see the issue notes): the bound is loose."""
    result, summary = run_text(acoustic_text(tdma=True), tmp_path / "tdma.mcap")
    assert result.link_stats is not None
    for link in result.link_stats["links"]:
        assert "collision" not in link["dropped"] and "half_duplex" not in link["dropped"]
        assert link["sent"] <= 400 / 12 + 1
    assert summary.phases[0].final_coordination_error < 1.0
    assert summary.phases[2].final_coordination_error < 1.0
    assert summary.max_path_error_after_transient <= summary.tube_radius


def test_a_run_shorter_than_the_transient_does_not_judge_the_tube(tmp_path, paper_text):
    from supervisor.analysis.summary import format_summary

    _, summary = run_text(shortened(paper_text, 5.0), tmp_path / "short.mcap")
    text = format_summary(summary)
    assert "none (the run ends within it)" in text and "nan" not in text and "OUTSIDE" not in text


@pytest.mark.parametrize("name", ["examples/micromodem_tdma.toml", "examples/every_fault.toml"])
def test_a_run_without_a_log_counts_the_messages_its_log_holds(tmp_path: Path, name: str) -> None:
    """A sweep's run counts its messages without building them (a Tally): as many as the log of the same run holds,
    where vehicles do not transmit at every step (TDMA) and where they are killed and restarted (a restart resumes
    from the last state's record)."""
    text = shortened((CONFIGS / name).read_text(), 60.0)
    scenario = parse_scenario(text, "s.toml")
    quiet = lambda: Progress(scenario.scenario.duration, io.StringIO(), enabled=False)  # noqa: E731
    logged = run_inprocess(scenario, "s.toml", text, tmp_path / "run.mcap", 1, quiet(), scene=False)
    bare = run_inprocess(scenario, "s.toml", text, None, 1, quiet())
    assert bare.messages == logged.messages == len(read_messages(tmp_path / "run.mcap"))
    assert bare.link_counts == logged.link_counts
    for name in ("gamma", "gamma_dot", "path_error"):
        assert np.array_equal(getattr(bare.series, name), getattr(logged.series, name), equal_nan=True), name


def test_a_run_without_a_log_gives_the_same_result_and_writes_nothing(paper_run, tmp_path, monkeypatch):
    """A sweep keeps only each run's metrics (out=None): the series, counts and message count of a run that
    records must come out the same, and no file may be written."""
    result, _, _ = paper_run
    text = (CONFIGS / "paper.toml").read_text()
    scenario = parse_scenario(text, "test.toml")
    monkeypatch.chdir(tmp_path)
    quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
    bare = run_inprocess(scenario, "test.toml", text, None, scenario.scenario.seed, quiet)
    assert list(tmp_path.iterdir()) == []
    assert bare.messages == result.messages and bare.link_counts == result.link_counts
    for name in ("t", "gamma", "gamma_dot", "path_error"):
        assert np.array_equal(getattr(bare.series, name), getattr(result.series, name), equal_nan=True), name


def test_a_run_without_a_log_counts_every_message_under_every_fault_kind(tmp_path):
    """Without a log (a sweep's run) the engine counts the messages it does not build: the rx batches and link
    events, the drops of the packets a killed broker and the end of the run leave in flight included. The count,
    the link books and the series must be those of the same run recorded."""
    faults = [
        "kind=link_down,sender=1,receiver=2,start=10,end=15",
        "kind=link_degraded,sender=1,receiver=3,extra_loss=0.5,extra_delay=0.3,start=5,end=25",
        "kind=blackout,start=20,end=22",
        "kind=modem_silent,vehicle=3,start=30,end=33",
        "kind=vehicle_kill,vehicle=2,start=41,end=44",
        "kind=link_degraded,sender=1,receiver=3,extra_delay=0.55,start=45",  # packets in flight at the kill, the end
        "kind=broker_kill,start=46,end=48",
    ]
    text = shortened((CONFIGS / "paper.toml").read_text(), 60.0)
    scenario = parse_scenario(text, "test.toml", [], faults)
    quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
    out = tmp_path / "run.mcap"
    recorded = run_inprocess(scenario, "test.toml", text, out, 7, quiet)
    bare = run_inprocess(scenario, "test.toml", text, None, 7, quiet)
    messages = read_messages(out)
    topics = Counter(topic for topic, _, _ in messages)
    reasons = Counter(m.get("reason") for m in link_events(messages))
    assert reasons["broker_down"] > 0 and reasons["end_of_run"] > 0 and topics["cpf/vehicle/1/rx"] > 0
    run_topics = sum(n for topic, n in topics.items() if not topic.startswith("foxglove/"))
    assert bare.messages == recorded.messages == run_topics and recorded.scene_messages > bare.scene_messages == 0
    assert bare.link_counts == recorded.link_counts and bare.link_stats == recorded.link_stats
    for name in ("gamma", "gamma_dot", "path_error"):
        assert np.array_equal(getattr(bare.series, name), getattr(recorded.series, name), equal_nan=True), name

"""Forged and malformed messages on the keys a process owns (a buggy or compromised vehicle or broker): every reader
counts and drops them, nothing unchecked reaches the log, and the run's summary prints the counts.

Unit tests feed the supervisor's intake (supervisor.engine.intake.Intake.take) directly, hypothesis-generated
payloads included; one end-to-end run is attacked from a session holding vehicle 2's credential, on vehicle 2's keys.
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path
from typing import Any

import pytest
import zenoh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from comms.bus.bus import Received
from comms.records.messages import (
    COMMS_DONE_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    SUPERVISOR_ALIVE,
    TICK_KEY,
    encode,
    state_key,
    step_message,
    tick_message,
    vehicle_done_key,
)
from comms.records.reports import SUPERVISOR
from comms.records.state import NeighbourAge, StateReport
from supervisor.config.scenario import parse_scenario
from supervisor.engine.intake import Intake
from supervisor.record.recorder import Recorder, read_messages
from tests.conftest import CONFIGS, link_events
from tests.procs import cpf
from tests.run_digest import digest
from tests.test_bus_access import WAIT, arrivals, client, read_credential, run_with_vehicle_2_by_hand, until

SCENARIO = parse_scenario((CONFIGS / "paper.toml").read_text())
DT = SCENARIO.scenario.step
STATE = StateReport(
    DT, 1, 2, 4.25, 0.98, (1.0, -2.0, 3.0), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.2, 0.1, 0.0),
    (0.0, 0.0, 0.3), (0.5, -0.25, 0.0), (10.0, 3.0), -0.02, 0.75, 0, (NeighbourAge(1, 0.5),),
).to_message()  # fmt: skip
STATS = {"t": 10.0, "window": 10.0, "horizon": 10.0, "lambda2": 1.0, "links": []}
DONE = {"t": 10.0, "k": 100, "events": 0, "malformed": 0}


def step(**changes: Any) -> bytes:
    return encode(step_message({**STATE, **changes}, None, None))


ISSUE_EXAMPLES = [
    (state_key(2), encode({"k": 5})),  # a KeyError once
    (state_key(2), step(vehicle=99)),  # a vehicle that is not its key's
    (state_key(99), step(vehicle=99)),  # a vehicle the run does not have
    (state_key(2), step(estimate_age=5)),
    (state_key(2), step(t=math.inf)),
    (state_key(2), step(k=10**7, t=10**7 * DT)),  # a step outside the run
    (state_key(2), step(k=3)),  # t = dt is not step 3's time
    (state_key(2), step(gamma=2**64 - 1)),  # an integer the log cannot hold
    (state_key(2), step(tau=[0.0] * 100_000, k=-1)),
    (state_key(2), b"\xc1 random bytes"),
    (COMMS_STATS_KEY, encode({**STATS, "t": math.inf})),
    (COMMS_STATS_KEY, encode({**STATS, "t": math.nan})),
    (COMMS_STATS_KEY, encode({**STATS, "links": [{"sender": 1, "receiver": 9, "sent": 1, "delivered": 0,
                                                  "dropped": {}, "mean_delay": None, "max_delay": None}]})),
    (COMMS_DONE_KEY, encode({"t": -1.0})),
    (COMMS_DONE_KEY, encode({**DONE, "t": -1.0})),  # failed inside the MCAP writer's finish once
    (COMMS_DONE_KEY, encode({**DONE, "t": 1e11})),
    (COMMS_DONE_KEY, encode({**DONE, "events": -5})),
    (COMMS_EVENTS_KEY, encode({"t": 1.0, "k": 10, "events": [{"t": 1.0, "sender": 1, "receiver": 7, "seq": 1,
                                                              "kind": "sent", "delay": None, "reason": None}]})),
    (vehicle_done_key(2), encode({"t": 10.0, "k": 100, "vehicle": 3, "malformed": {}})),
    (vehicle_done_key(2), encode({"t": 10.0, "k": 100, "vehicle": 2, "malformed": {"x": -1}})),
    ("cpf/run/stop", encode({"t": 0.0, "reason": "forged"})),  # not a key the supervisor reads
]  # fmt: skip


def take_all(path: Path, items: list[tuple[str, bytes]]) -> Intake:
    """An intake on a fresh log fed items, the log closed (its finish must not fail)."""
    with Recorder(path) as rec:
        intake = Intake(SCENARIO, rec, None)
        for key, payload in items:
            intake.take(Received(key, payload), 0.0)
    return intake


def test_the_issues_forgeries_are_counted_by_key_and_dropped_and_the_log_closes(tmp_path: Path) -> None:
    intake = take_all(tmp_path / "run.mcap", ISSUE_EXAMPLES)
    assert intake.malformed.total() == len(ISSUE_EXAMPLES)
    assert intake.malformed[state_key(2)] == 9 and intake.malformed[COMMS_DONE_KEY] == 4
    assert intake.states == {} and intake.done is None and intake.vehicles_done == {}
    assert read_messages(tmp_path / "run.mcap") == []  # nothing reached the writer, and the log reads back


def test_well_formed_messages_are_recorded_in_their_records_form_and_booked(tmp_path: Path) -> None:
    """The control: the same keys with good payloads are taken in (an extra field is not carried into the log)."""
    report = {"t": 10.0, "k": 100, "vehicle": 2, "malformed": {COMMS_STEP_KEY: 3}}
    good = [(state_key(2), step(extra="not a state field")), (COMMS_STATS_KEY, encode(STATS)),
            (COMMS_DONE_KEY, encode({**DONE, "malformed": 4})), (vehicle_done_key(2), encode(report))]  # fmt: skip
    intake = take_all(tmp_path / "run.mcap", good)
    assert intake.malformed.total() == 0 and intake.states == {1: {2}}
    assert intake.bus_drops().by_key == {  # vehicles 1 and 3 sent no report: their drops are unknown
        SUPERVISOR: {},
        "broker": {"any key": 4},
        "vehicle 1": None,
        "vehicle 2": {COMMS_STEP_KEY: 3},
        "vehicle 3": None,
    }
    records = read_messages(tmp_path / "run.mcap")
    assert [topic for topic, _, _ in records] == [state_key(2), COMMS_STATS_KEY, COMMS_DONE_KEY, vehicle_done_key(2)]
    assert records[0][2] == STATE


KEYS = [state_key(2), COMMS_STATS_KEY, COMMS_DONE_KEY, COMMS_EVENTS_KEY, vehicle_done_key(2)]
INTEGERS = st.integers(-(2**63), 2**64 - 1)  # what msgpack carries
VALUES = st.one_of(
    st.none(), st.booleans(), INTEGERS, st.floats(), st.text(max_size=5),
    st.lists(st.floats(), max_size=4), st.dictionaries(st.text(max_size=3), INTEGERS, max_size=3),
)  # fmt: skip
BASES = {state_key(2): STATE, COMMS_STATS_KEY: STATS, COMMS_DONE_KEY: DONE, vehicle_done_key(2): {**DONE, "vehicle": 2}}


@st.composite
def forged(draw: st.DrawFn) -> tuple[str, bytes]:
    """A payload on a key the supervisor reads: random bytes, a random map, or a good message with one field changed
    or removed."""
    key = draw(st.sampled_from(KEYS))
    how = draw(st.sampled_from(["bytes", "map", "field"]))
    if how == "bytes":
        return key, draw(st.binary(max_size=64))
    if how == "map":
        return key, encode(draw(st.dictionaries(st.text(max_size=8), VALUES, max_size=6)))
    base = dict(BASES.get(key, {"t": 1.0, "k": 10, "events": []}))
    name = draw(st.sampled_from(sorted(base)))
    if draw(st.booleans()):
        del base[name]
    else:
        base[name] = draw(VALUES)
    return key, encode(step_message(base, None, None) if key == state_key(2) else base)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(forged(), min_size=1, max_size=8))
def test_no_payload_on_any_key_ends_in_a_traceback_or_an_unchecked_record(items: list[tuple[str, bytes]]) -> None:
    """Whatever comes: no exception, the log closes and reads back, and every record in it reads as its record."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.mcap"
        intake = take_all(path, items)
        records = read_messages(path)
    taken = [item for item in items if item[0] != COMMS_EVENTS_KEY]  # an empty batch of events records nothing
    assert intake.malformed.total() + len(records) >= len(taken)  # each message either recorded or counted
    for topic, stamp, message in records:
        assert 0 <= stamp <= (SCENARIO.scenario.duration + 60) * 1e9
        if topic == state_key(2):
            report = StateReport.from_message(message, 2)
            assert 0 <= report.k < 1000 and report.t == pytest.approx(report.k * DT)


# --- a run, attacked from vehicle 2's own keys ----------------------------------------------------------------


E2E_FORGED = [
    encode({"k": 5}), b"\xc1 random bytes", step(vehicle=99), step(estimate_age=5), step(t=math.nan),
    step(k=0, t=5.0), step(k=10**7, t=10**7 * DT), step(k=10**7, tau=[0.0] * 100_000),
]  # fmt: skip
E2E_DONE = [encode({"t": -1.0}), encode({"t": 1e11, "k": 1, "vehicle": 2, "malformed": {}})]


@pytest.mark.integration
@pytest.mark.e2e
def test_a_run_attacked_on_a_vehicles_own_keys_counts_drops_and_says_so(tmp_path: Path, paper_text: str) -> None:
    """cpf run with vehicle 2 started by hand; a second session with vehicle 2's credential publishes malformed and
    wrong payloads on vehicle 2's state and done keys. The run ends normally, its records are those of the same
    scenario run undisturbed, and the summary names the counts; `cpf report` of its log says the same (it said
    nothing of them: the supervisor's own drops were not in the log)."""
    with run_with_vehicle_2_by_hand(tmp_path, paper_text, "--metrics", "m.json") as hand:  # noqa: SIM117 - the
        with client(hand.endpoint, read_credential(hand.path)) as forger:  # credential exists only inside the run
            steps = arrivals(forger, COMMS_STEP_KEY)
            hand.start_vehicle()
            until(steps, COMMS_STEP_KEY, times=3)  # step 0 is in the broker's water: a forged step 0 is stale
            # BLOCK, as the run's own publishers: with zenoh's default (drop when the link's queue is full) a loaded
            # machine dropped the forgeries behind the 0.8 MB one, so the counts below missed them (issue 27).
            for payload in E2E_FORGED:
                forger.put(state_key(2), payload, congestion_control=zenoh.CongestionControl.BLOCK)
            for payload in E2E_DONE:
                forger.put(vehicle_done_key(2), payload, congestion_control=zenoh.CongestionControl.BLOCK)
            list(forger.liveliness().get(SUPERVISOR_ALIVE, timeout=WAIT))  # a round trip: the forgeries are in
            assert hand.run.poll() is None  # ... while the run goes on: the supervisor takes in all the router gave
    out, err = hand.out, hand.err
    assert "Traceback" not in err, err
    supervisor = f"supervisor: {len(E2E_DONE)} on {vehicle_done_key(2)}, {len(E2E_FORGED)} on {state_key(2)}"
    line = next(line for line in out.splitlines() if line.startswith("bus: "))
    assert supervisor in line and "broker: " in line and "vehicle 1: 0" in line, line
    counts = json.loads((tmp_path / "m.json").read_text())["malformed"]
    assert counts[SUPERVISOR] == {state_key(2): len(E2E_FORGED), vehicle_done_key(2): len(E2E_DONE)}
    assert counts["broker"][state_key(2)] >= 5  # what the broker's own reading refuses, on the key that carried it
    assert set(counts) == {SUPERVISOR, "broker", "vehicle 1", "vehicle 2", "vehicle 3"}
    records = read_messages(tmp_path / "run.mcap")
    dones = [m["vehicle"] for topic, _, m in records if topic.endswith("/done") and "vehicle" in topic]
    assert sorted(dones) == [1, 2, 3]  # each vehicle's own report, none forged
    assert not [event for event in link_events(records) if event["t"] < 0]
    assert digest(tmp_path / "run.mcap") == hand.undisturbed_digest()
    report = cpf("report", "run.mcap", "--out", "report", cwd=tmp_path)
    assert report.returncode == 0 and line in report.stdout.splitlines(), report.stdout + report.stderr
    written, ran = (json.loads(path.read_text()) for path in (tmp_path / "report/metrics.json", tmp_path / "m.json"))
    assert (written["malformed"], written["dropped_by_cause"]) == (ran["malformed"], ran["dropped_by_cause"])


def test_the_broker_keeps_no_state_from_beyond_the_clock():
    """A vehicle's credential can publish states on its own key: one claiming a step far ahead of the clock would be
    held by the broker for ever (memory), so it is counted and dropped like any malformed message."""
    from comms.broker.broker import Broker
    from supervisor.config.fleet import broker_core
    from tests.conftest import RecordingPublishers

    broker = Broker(broker_core(SCENARIO, 0), SCENARIO.vehicle_ids, RecordingPublishers(), DT)
    broker.take(state_key(2), step(k=10**6, t=10**6 * DT))
    assert broker.books.malformed == 1 and not broker.books.states
    broker.take(state_key(2), step(k=0, t=0.0))  # the first step: not before its tick (a vehicle steps on one)
    assert broker.books.malformed == 2 and not broker.books.states
    broker.take(TICK_KEY, encode(tick_message(0, 0.0, False)))
    broker.take(state_key(2), step(k=0, t=0.0))
    assert broker.books.malformed == 2 and list(broker.books.states) == [0]


def test_an_end_of_run_report_of_drops_on_many_keys_still_reads(tmp_path: Path) -> None:
    """Drops on the keys of 70 vehicles: the supervisor's report (and the broker's and a vehicle's, the same
    Drops.reported) carried 70 keys where a report reads at most 64, so cpf report skipped it (the review). Now the
    63 keys with the most and the rest as 'other keys', every drop counted."""
    import logging

    from comms.records.drops import OTHER_KEYS, Drops
    from comms.records.reports import MAX_KEYS, SupervisorDone

    drops = Drops(logging.getLogger("test"), SUPERVISOR)
    for vid in range(1, 71):
        for _ in range(1 + (vid == 7)):
            drops.drop(state_key(vid), ValueError("not a state"))
    by_key, by_cause = drops.reported()
    done = SupervisorDone.from_message(SupervisorDone(1.0, 10, by_key, by_cause).to_message())
    assert len(done.malformed) == MAX_KEYS and sum(done.malformed.values()) == 71
    assert done.malformed[state_key(7)] == 2 and done.malformed[OTHER_KEYS] == 71 - 2 - (MAX_KEYS - 2)


def test_a_reader_that_sent_no_report_is_said_so_not_counted_as_none() -> None:
    """A Zenoh run that aborted before the broker reported: the line listed the supervisor's 10 drops and the
    vehicles' 0 and said nothing of the broker, which had dropped 10 more (a new user read it as none)."""
    from comms.records.reports import SupervisorDone, VehicleDone, bus_drops, bus_readers
    from supervisor.analysis.comms_summary import format_malformed

    supervisor = SupervisorDone(5.0, 50, {state_key(3): 10}, {"malformed": 10})
    vehicles = {1: VehicleDone(5.0, 50, 1, {}), 2: VehicleDone(5.0, 50, 2, {})}
    drops = bus_drops(supervisor, None, vehicles, bus_readers([1, 2, 3]))
    assert drops.by_key["broker"] is None and drops.by_key["vehicle 3"] is None and drops.by_key["vehicle 1"] == {}
    line = format_malformed(*drops)
    assert line == (
        f"bus: 10 messages dropped (supervisor: 10 on {state_key(3)} [10 malformed], broker: no report, vehicle 1: 0, "
        "vehicle 2: 0, vehicle 3: no report)"
    )

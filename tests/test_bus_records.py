"""The intake's one-pass reading (comms.records.bus_records): its structs are the records' own, their log form is the
bytes the records' to_message gives through orjson, and on any payload (good, altered anywhere, windows of several
steps, link events) the intake records, counts and books exactly what the slow reading (decode, then each record's
from_message) does; but for what msgspec skips unchecked with a field no record has (a value nested deeper than the
bounded reader takes, map keys of other types, text that is not UTF-8), which the slow reading refuses and the
strategies here do not make (comms.records.bus_records)."""

from __future__ import annotations

import copy
import math
import sys
from collections.abc import Iterable
from typing import Any

import orjson
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from comms.bus.bus import Received
from comms.records import bus_records
from comms.records.bus_records import log_json, read_events, read_window
from comms.records.messages import COMMS_EVENTS_KEY, META_KEY, encode, state_key, step_message, window_message
from comms.records.receptions import Delivery, RxBatch
from comms.records.records import LinkEvent, Transmission
from comms.records.state import NeighbourAge, StateReport
from supervisor.config.scenario import parse_scenario
from supervisor.engine import intake as intake_module
from supervisor.engine.intake import Intake
from supervisor.engine.realtime_timing import RealtimeTiming
from supervisor.record.meta import RunMeta
from supervisor.record.recorder import JSON_OPTIONS
from supervisor.record.scene.scene import FleetScene
from tests.conftest import CONFIGS

SCENARIO = parse_scenario((CONFIGS / "paper.toml").read_text())
DT = SCENARIO.scenario.step


def state(k: int, **changes: Any) -> dict[str, Any]:
    report = StateReport(
        k * DT, k, 2, 4.25, 0.98, (1.0, -2.0, 3.0), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (1.2, 0.1, 0.0),
        (0.0, 0.0, 0.3), (0.5, -0.25, 0.0), (10.0, 3.0), -0.02, 0.75, k, (NeighbourAge(1, 0.5),),
    )  # fmt: skip
    return {**report.to_message(), **changes}


TX = Transmission(2, 9, 2 * DT, 4.25, 0.98, (1.0, -2.0, 3.0), (1.2, 0.1, 0.0)).to_message()
RX = RxBatch(2 * DT, 2, 2, (Delivery(1, 4, 0.1, 0.11, 5.0, 1.0), Delivery(1, 5, 0.15, 0.16, 4.0, 0.9))).to_message()
EVENT = {"t": 0.2, "sender": 1, "receiver": 2, "seq": 1, "kind": "delivered", "delay": 0.01, "reason": None}
DROPPED = {**EVENT, "seq": 2, "kind": "dropped", "delay": None, "reason": "loss"}
EVENTS = {"t": 0.2, "k": 2, "events": [EVENT, DROPPED, {**EVENT, "t": 0.5, "kind": "sent", "delay": None}]}
STEP = step_message(state(2), TX, RX, 3)
WINDOW = window_message([step_message(state(1), None, RX), step_message(state(2), TX, RX)], 4)

BOUNDARIES = [0.0, -0.0, 1, -1, 2**63 - 1, -(2**63), 2**64 - 1, 1e16, 1e22, -1e300, sys.float_info.max, math.inf,
              -math.inf, math.nan, 1e-300, 150.0, 0.1, 2, 3, 9]  # fmt: skip
SCALARS = st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.floats() | st.text(max_size=3)
VALUES = st.recursive(
    SCALARS | st.sampled_from(BOUNDARIES) | st.lists(st.floats() | st.sampled_from(BOUNDARIES), min_size=2, max_size=9),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=3),
    max_leaves=8,
)


@st.composite
def altered(draw: st.DrawFn, message: dict[str, Any]) -> dict[str, Any]:
    """message with one place anywhere in it (a field, a nested field, a list item) replaced or removed, or a field
    added."""
    out = copy.deepcopy(message)
    node: Any = out
    while True:
        keys = list(node) if isinstance(node, dict) else list(range(len(node)))
        key = draw(st.sampled_from(keys))
        child = node[key]
        if isinstance(child, dict | list) and child and draw(st.booleans()):
            node = child
            continue
        break
    how = draw(st.sampled_from(["replace", "remove", "add"]))
    if how == "replace":
        node[key] = draw(VALUES)
    elif how == "remove":
        del node[key]
    elif isinstance(node, dict):
        node[draw(st.sampled_from(["extra", "tx", "rx", "next_tx", "earlier", "due", "stamp"]))] = draw(VALUES)
    return out


class Capture:
    """A recorder that keeps what would be written, in its log form, and feeds a Foxglove scene as the Recorder
    does."""

    def __init__(self) -> None:
        self.records: list[tuple[str, float, bytes]] = []
        self.scene = FleetScene()
        self.scene.take(META_KEY, RunMeta.of(SCENARIO, "paper.toml", "", 0, "zenoh", "lockstep").to_message())

    def write(self, key: str, t: float, message: dict[str, Any]) -> bool:
        self.records.append((key, t, orjson.dumps(message, option=JSON_OPTIONS)))
        self.scene.take(key, message)
        return True

    def write_json(self, key: str, t: float, data: bytes) -> bool:
        self.records.append((key, t, data))
        return True

    def write_state(self, key: str, t: float, data: bytes, report: StateReport) -> None:
        self.write_json(key, t, data)
        self.scene.take_state(report)

    def write_events(self, key: str, t: float, data: bytes, events: Iterable[LinkEvent]) -> None:
        self.write_json(key, t, data)
        for event in events:
            self.scene.take_event(event)


def taken(items: list[tuple[str, bytes]], typed: bool) -> tuple[Any, ...]:
    """Everything the intake leaves behind after taking items (typed: its one-pass reading; else the slow one)."""
    rec = Capture()
    intake = Intake(SCENARIO, rec, None)  # type: ignore[arg-type]  # Capture does what the intake asks of a Recorder
    if not typed:
        intake._typed = lambda key, payload: False  # type: ignore[method-assign]
    for key, payload in items:
        intake.take(Received(key, payload), 0.0)
    h = rec.scene.history
    return (rec.records, dict(intake.malformed), intake.states, intake.last_state, intake.last_seq, intake.next_tx,
            intake.broker_events, intake.books.counts, h.states, h.outcomes)  # fmt: skip


def same_either_way(items: list[tuple[str, bytes]]) -> None:
    assert repr(taken(items, typed=True)) == repr(taken(items, typed=False))  # repr: NaN is not NaN, 'nan' is


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(altered(STEP) | altered(WINDOW))
@example(STEP)
@example(WINDOW)
@example({**STEP, "tx": {**TX, "stamp": TX["t"]}})  # a stamp equal to t
@example({**STEP, "tx": {**TX, "t": 0.0, "stamp": -0.0}})  # ... and one equal but printed otherwise
@example({**STEP, "gamma": 1e22, "lyapunov": math.nan, "correction": 2**63 - 1})
@example({**STEP, "nav_estimate": [0.0] * 27, "nav_fix": None})
@example({**STEP, "gamma": 2**63})  # msgspec refuses, the checks accept
@example({**STEP, "tx": {**TX, "velocity": [150.0, 0.0, 0.0]}})  # faster than any vehicle: the transmission dropped
@example({**STEP, "tx": {**TX, "sender": 3}})
@example({**STEP, "tx": {**TX, "t": 1e6}})  # outside the run
@example({**STEP, "rx": {**RX, "receptions": [{**RX["receptions"][0], "sender": 3}]}})  # no link 3->2
@example({**STEP, "rx": {**RX, "vehicle": 1}})
@example({**STEP, "rx": {**RX, "t": -1.0}})
@example({**STEP, "velocity": [150.0, 0.0, 0.0]})  # the whole message dropped
@example({**STEP, "rotation": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.1]})
@example({**STEP, "vehicle": 1})
@example({**STEP, "estimate_age": [{"vehicle": 7, "age": 0.5}]})
@example({**STEP, "k": 3})
@example({**WINDOW, "earlier": [{**WINDOW["earlier"][0], "k": 5}]})  # the earlier step recorded, then refused
def test_a_step_message_is_taken_in_the_same_either_way(message: dict[str, Any]) -> None:
    same_either_way([(state_key(2), encode(message))])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(altered(EVENTS))
@example(EVENTS)
@example({**EVENTS, "events": [{**EVENT, "delay": 1}]})  # an integer delay reads as a float either way
@example({**EVENTS, "events": [{**EVENT, "receiver": 3}]})  # no link 1->3... there is: 3 receives from 1
@example({**EVENTS, "events": [{**EVENT, "sender": 2, "receiver": 3}]})  # no link 2->3: counted, not booked
@example({**EVENTS, "events": [{**EVENT, "seq": -1}, {**EVENT, "delay": -0.5}, {**EVENT, "t": 1e6}]})
@example({**EVENTS, "k": 10**6})
@example({**EVENTS, "t": -1.0})
def test_link_events_are_taken_in_the_same_either_way(message: dict[str, Any]) -> None:
    same_either_way([(COMMS_EVENTS_KEY, encode(message))])


def test_good_messages_are_read_in_one_pass(monkeypatch: pytest.MonkeyPatch) -> None:
    """A well-formed step message, window and batch of link events never go through the slow reading."""

    def slow(_: bytes) -> dict[str, Any]:
        raise AssertionError("read the slow way")

    monkeypatch.setattr(intake_module, "decode", slow)
    records, malformed, states, *_ = taken([(state_key(2), encode(WINDOW)), (COMMS_EVENTS_KEY, encode(EVENTS))], True)
    assert malformed == {} and states == {1: {2}, 2: {2}} and len(records) == 2 + 2 + 1 + 1  # the events: one batch
    assert len(orjson.loads(records[-1][2])["events"]) == 3  # all of EVENTS


def test_a_realtime_step_is_timed_and_recorded_the_same_either_way() -> None:
    """Realtime runs read step messages in one pass too (they read the slow way, so the supervisor dropped what the
    broker took): the timing (how late receptions were taken in, when steps began) and the records are the same."""
    realtime = {**state(2), "rx_lateness": [0.01, -0.002], "step_lateness": 0.004}
    due = {**RX, "receptions": [{**r, "due": 1000.0 + r["arrival"]} for r in RX["receptions"]]}
    items = [(state_key(2), encode(step_message(realtime, TX, due, 3)))]
    seen = []
    for typed in (True, False):
        rec = Capture()
        timing = RealtimeTiming(DT)
        intake = Intake(SCENARIO, rec, timing)  # type: ignore[arg-type]  # Capture does what a Recorder is asked
        if not typed:
            intake._typed = lambda key, payload: False  # type: ignore[method-assign]
        for key, payload in items:
            intake.take(Received(key, payload), 0.0)
        seen.append((rec.records, timing.reached, timing.began, timing.receptions, timing.taken_late))
    assert seen[0] == seen[1] and seen[0][1] == [0.01, -0.002] and seen[0][3] == 2


# Finite numbers of any size: a NaN or an infinity is dropped as not finite (test_a_non_finite_state_is_dropped).
FLOATS = st.floats(allow_nan=False, allow_infinity=False) | st.sampled_from(
    [b for b in BOUNDARIES[5:] if not (isinstance(b, float) and not math.isfinite(b))]
)


@settings(max_examples=300, deadline=None)
@given(st.lists(FLOATS, min_size=8, max_size=8), st.booleans())
def test_the_log_form_is_orjsons_of_the_record(values: list[float], navigation: bool) -> None:
    """Numbers of any size (msgspec writes 1e22 where orjson writes 1e+22: the log form is orjson's)."""
    a, b, c, d, e, f, g, h = values
    message = state(2, gamma=a, gamma_dot=b, error=[c, d, e], correction=f, lyapunov=g, tau=[h, a])
    if navigation:
        message |= {"nav_estimate": [a] * 27, "nav_fix": 1}
    read = read_window(encode(message))
    if read is not None:  # msgspec refuses some (an integer beyond int64): the intake then reads the slow way
        assert log_json(read[0][0].state) == orjson.dumps(StateReport.from_message(message, 2).to_message())
    tx_message = {**TX, "gamma": f, "gamma_dot": g, "position": [a, b, c]}
    read = read_window(encode(step_message(state(2), tx_message, None)))
    if read is not None and read[0][0].tx is not None:
        tx = Transmission.from_message(tx_message, 2)
        assert log_json(read[0][0].tx) == orjson.dumps(tx.to_message())
    events = read_events(encode({**EVENTS, "events": [{**EVENT, "t": abs(a), "delay": b}]}))
    if events is not None:
        event = events.events[0]
        assert log_json(event) == orjson.dumps(event.to_message())


def test_refused_payloads_read_as_none() -> None:
    assert read_window(b"\xc1") is None and read_events(b"\x90") is None
    assert read_window(encode({**STEP, "next_tx": "soon"})) is None
    assert bus_records.read_window(encode(STEP)) is not None

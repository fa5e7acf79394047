"""The broker's reading of step messages (comms.broker.step_reading): in one pass of msgspec where it reads, the slow
way where it refuses; on any payload (good, altered anywhere, windows, a window run past transmissions) the broker
files and counts exactly what the slow reading alone does (but for what msgspec skips unchecked with an unknown field:
comms.records.bus_records), and takes the same messages as the supervisor's intake."""

from __future__ import annotations

import math
from typing import Any
from unittest.mock import patch

import pytest
from hypothesis import HealthCheck, example, given, settings

from comms.broker import step_reading
from comms.broker.broker import Broker
from comms.broker.lookahead import Replay
from comms.bus.bus import Received
from comms.records.messages import TICK_KEY, encode, state_key, tick_message
from supervisor.config.fleet import broker_core
from supervisor.engine.intake import Intake
from supervisor.engine.realtime_timing import RealtimeTiming
from tests.conftest import RecordingPublishers
from tests.test_bus_records import DT, RX, SCENARIO, STEP, TX, WINDOW, Capture, altered, state


def broker_after(payload: bytes, typed: bool = True, whole: bool = False) -> Broker:
    """A broker after a tick of step 2, then payload on vehicle 2's state key (typed: its one-pass reading, else the
    slow one alone; whole: a window run past transmissions is pending, so every step is read)."""
    broker = Broker(broker_core(SCENARIO, 0), SCENARIO.vehicle_ids, RecordingPublishers(), DT)
    broker.books.taken.clear()  # told no vehicle's next step: these test the reading of one message, whatever its
    # steps (a window from step 1, a step 2), as the supervisor's intake here (the turns: test_stream_turns.py)
    broker.take(TICK_KEY, encode(tick_message(2, 2 * DT, False)))
    if whole:
        broker.replay = Replay(0, 3, [{}, {}])
    with patch.object(step_reading, "read_window", step_reading.read_window if typed else lambda _: None):
        broker.take(state_key(2), payload)
    return broker


def filed(payload: bytes, typed: bool, whole: bool) -> str:
    """Everything broker_after holds (repr: NaN is not NaN, 'nan' is)."""
    broker = broker_after(payload, typed, whole)
    books, drops = broker.books, broker.books.drops
    return repr((books.states, books.taken, books.last, drops.by_key, drops.by_cause, drops.last, broker.grants))


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(altered(STEP) | altered(WINDOW))
@example(STEP)
@example(WINDOW)
@example({**STEP, "tx": {**TX, "velocity": [150.0, 0.0, 0.0]}})  # the transmission dropped, the state kept
@example({**STEP, "tx": {**TX, "sender": 3}})
@example({**STEP, "tx": {**TX, "t": 1e6}})  # not at its step's time
@example({**STEP, "tx": [1, 2]})
@example({**STEP, "rx": {**RX, "vehicle": "x"}})  # the broker does not read the batch: msgspec refuses, slow accepts
@example({**STEP, "velocity": [150.0, 0.0, 0.0]})
@example({**STEP, "gamma": 2**63, "lyapunov": math.nan})
@example({**STEP, "next_tx": True})
@example({**WINDOW, "earlier": [{**WINDOW["earlier"][0], "k": 5}]})
@example({**WINDOW, "earlier": [{**WINDOW["earlier"][0], "rotation": [2.0] * 9}]})
def test_a_step_message_is_filed_the_same_either_way(message: dict[str, Any]) -> None:
    payload = encode(message)
    for whole in (False, True):
        assert filed(payload, True, whole) == filed(payload, False, whole)


def test_good_messages_are_read_in_one_pass(monkeypatch: pytest.MonkeyPatch) -> None:
    """A well-formed step message and window never go through the slow reading."""

    def slow(_: bytes) -> dict[str, Any]:
        raise AssertionError("read the slow way")

    monkeypatch.setattr(step_reading, "decode", slow)
    for message in (STEP, WINDOW):
        broker = broker_after(encode(message))
        assert broker.books.drops.total == 0 and broker.books.states[2][2][1] is not None  # its transmission kept


def test_the_broker_takes_the_step_messages_the_supervisor_records() -> None:
    """A state the supervisor records must be on the channel, and one it drops must not: a value nested deeper than
    the bounded reader takes, in a field no reader keeps, is skipped by msgspec. The broker read it the slow way and
    dropped the message (too deep) while the supervisor recorded it: the channel then lacked a state the log had. In a
    realtime run the supervisor read every message the slow way, and then dropped what the broker took."""
    deep: Any = 1.0
    for _ in range(40):
        deep = [deep]
    for message in ({**STEP, "extra": deep}, {**STEP, "extra": 1}, {**STEP, "gamma": "x"}):
        for timing in (None, RealtimeTiming(DT)):  # lockstep, realtime (which the supervisor read the slow way)
            intake = Intake(SCENARIO, Capture(), timing)  # type: ignore[arg-type]  # Capture does what it is asked
            intake.take(Received(state_key(2), encode(message)), 0.0)
            broker = broker_after(encode(message))
            assert (2 in intake.states.get(2, ())) == (2 in broker.books.states.get(2, {})), (message, timing)


def test_a_window_state_is_checked_only_where_it_is_read() -> None:
    """An earlier step the broker does not need (no window run past transmissions) is not read: a bad one leaves the
    window's last step filed; one it needs drops the message whole."""
    bad = encode({**WINDOW, "earlier": [{**state(1), "rotation": [2.0] * 9}]})
    assert list(broker_after(bad).books.states) == [2]
    dropped = broker_after(bad, whole=True)
    assert not dropped.books.states and dict(dropped.books.drops.by_key) == {state_key(2): 1}

"""Every reader of bus bytes (the supervisor's intake both ways, the broker, a vehicle, a hello reply, the replay's
control queryable) on arbitrary bytes and arbitrary msgpack, deep, wide and huge, valid messages altered anywhere:
each message is a counted drop or a valid record, never an exception (issue 31: one message must never stop a run).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from comms.broker.broker import Broker
from comms.bus.bus import Received
from comms.records.bounded import MAX_BYTES, MAX_DEPTH, TOO_DEEP, TOO_LARGE, brief, cause_of, read_bytes
from comms.records.messages import (
    COMMS_DONE_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    TICK_KEY,
    Hello,
    batches_message,
    encode,
    rx_key,
    state_key,
    tick_message,
    vehicle_done_key,
)
from supervisor.config.fleet import broker_core
from supervisor.config.plausibility import plausibility
from supervisor.engine import intake as intake_module
from supervisor.engine.intake import Intake
from supervisor.engine.startup import read_hello
from supervisor.tools.replay_control import Control
from supervisor.tools.replay_player import Player
from tests.conftest import RecordingPublishers
from tests.test_bus_records import DT, EVENTS, RX, SCENARIO, STEP, VALUES, WINDOW, Capture, altered
from tests.test_vehicle_node import VID, vehicle

ISSUE_31 = b"\x81\xa7earlier" + b"\x91" * 1500 + b"\x01"  # the attack of issue 31, on vehicle 2's state key
DEEP = st.integers(1, 3000).map(lambda n: b"\x91" * n + b"\x01")
# A 4-billion-item array or map, a 4 GB string or blob: announced, never sent.
WIDE = st.sampled_from([b"\xdd\xff\xff\xff\xff", b"\xdf\xff\xff\xff\xff\x01", b"\xc6\xff\xff\xff\xff", b"\xdb\xff\xff"])
TICK = tick_message(0, 0.0, False)


def with_field(message: dict[str, Any], name: str, packed: bytes) -> bytes:
    """message's msgpack with one more field whose value is the raw bytes packed (which msgpack could not pack)."""
    head = b"\xde" + (len(message) + 1).to_bytes(2, "big")
    return head + b"".join(encode(k) + encode(v) for k, v in message.items()) + encode(name) + packed  # type: ignore[arg-type]


@st.composite
def payloads(draw: st.DrawFn, good: list[dict[str, Any]]) -> bytes:
    """Arbitrary bytes, arbitrary msgpack, a good message altered anywhere, or one with a deep or wide field."""
    kind = draw(st.sampled_from(["bytes", "msgpack", "altered", "deep field", "wide field", "deep"]))
    if kind == "bytes":
        return draw(st.binary(max_size=300))
    if kind == "msgpack":
        return encode(draw(VALUES))  # type: ignore[arg-type]  # msgpack packs any value
    if kind == "deep":
        return draw(DEEP)
    message = draw(st.sampled_from(good))
    if kind == "altered":
        return encode(draw(altered(message)))
    field = draw(st.sampled_from(["earlier", "next_tx", "tx", "rx", "gamma", "extra", "tick", "events", "k"]))
    return with_field(
        {k: v for k, v in message.items() if k != field}, field, draw(DEEP if kind == "deep field" else WIDE)
    )


def reader_examples(test: Callable[..., None]) -> Callable[..., None]:
    for payload in (ISSUE_31, bytes(MAX_BYTES + 1), b"\x81\xa7next_tx" + b"\x91" * 990 + b"\x01", b"", b"\xc1"):
        test = example(payload)(test)
    return settings(max_examples=50, deadline=None, suppress_health_check=list(HealthCheck))(test)


@pytest.mark.parametrize("typed", [True, False], ids=["one pass", "realtime (slow reading)"])
@pytest.mark.parametrize("key", [state_key(2), COMMS_EVENTS_KEY, COMMS_STATS_KEY, COMMS_DONE_KEY, vehicle_done_key(2)])
def test_the_supervisors_intake_drops_and_counts_or_records(
    key: str, typed: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    bounds = plausibility(SCENARIO)
    monkeypatch.setattr(intake_module, "plausibility", lambda sc: bounds)  # an intake per example: worked out once

    @reader_examples
    @given(payloads([STEP, WINDOW, EVENTS]))
    def take(payload: bytes) -> None:
        rec = Capture()
        intake = Intake(SCENARIO, rec, None)  # type: ignore[arg-type]  # Capture does what a Recorder is asked
        if not typed:
            intake._typed = lambda key, payload: False  # type: ignore[method-assign]
        intake.take(Received(key, payload), 0.0)
        taken = rec.records or intake.events_t > -math.inf  # (a batch of no link events records nothing)
        assert intake.drops.total >= 1 or taken  # (a part of a step message is dropped on its own)

    take()


@pytest.mark.parametrize("key", [state_key(2), TICK_KEY])
def test_the_broker_drops_and_counts_or_files(key: str) -> None:
    @reader_examples
    @given(payloads([STEP, WINDOW, TICK]))
    def take(payload: bytes) -> None:
        broker = Broker(broker_core(SCENARIO, 0), SCENARIO.vehicle_ids, RecordingPublishers(), DT)
        broker.take(key, payload)
        filed = broker.books.states or broker.books.ticks or broker.grants.grants  # a tick filed, or a span granted
        assert broker.books.drops.total >= 1 or filed

    take()


@pytest.mark.parametrize("key", [COMMS_STEP_KEY, rx_key(VID)])
def test_a_vehicle_drops_and_counts_or_files(key: str) -> None:
    batches = batches_message(TICK, {VID: []})

    node, _ = vehicle()  # one for every example (a scenario's reading each time is slow): what one message leaves
    pending = node.pending

    @reader_examples
    @given(payloads([batches, {**batches, "rx": None}, RX]))
    def take(payload: bytes) -> None:
        pending.ticks.clear()
        pending.batches.clear()
        pending.live.clear()
        dropped = pending.drops.total
        node(key, payload)
        assert pending.drops.total == dropped + 1 or (
            (pending.ticks or pending.live) and pending.drops.total == dropped
        )

    take()


@reader_examples
@given(payloads([Hello("vehicle", "0" * 64, {"graph": "1" * 64}).to_message()]))
def test_a_hello_reply_is_a_hello_or_a_named_drop(payload: bytes) -> None:
    try:
        assert isinstance(read_hello(payload), Hello)
    except ValueError as exc:
        assert cause_of(exc) and len(str(exc)) < 400  # the reason names it, never the whole value


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=1100) | st.text(alphabet='{}[]":,seekt=0123 ', max_size=1100).map(str.encode))
@example(b'{"command": "seek", "t": ' + b"[" * 1000)
@example(b'{"command": ' + b"[" * 500 + b"]" * 500 + b"}")
def test_the_replays_control_answers_every_query(payload: bytes) -> None:
    control = Control(Player(lambda t: iter([]), 1.0, (0.0, 10.0)), clock=lambda: 0.0)
    accepted, reply = control.answer(payload)
    assert accepted or (control.rejected == 1 and len(reply["error"]) < 400)


@pytest.mark.parametrize("depth", [MAX_DEPTH, MAX_DEPTH + 1, 1023, 1024, 5000])
def test_the_bounded_reader_holds_messages_to_its_depth(depth: int) -> None:
    payload = b"\x91" * depth + b"\x01"
    if depth <= MAX_DEPTH:
        assert read_bytes(payload) is not None
    else:
        with pytest.raises(ValueError) as refused:
            read_bytes(payload)
        assert cause_of(refused.value) == TOO_DEEP


def test_the_bounded_reader_refuses_a_message_larger_than_its_bound_before_reading_it() -> None:
    with pytest.raises(ValueError) as refused:
        read_bytes(bytes(MAX_BYTES + 1))
    assert cause_of(refused.value) == TOO_LARGE


def test_brief_cuts_any_value_short() -> None:
    deep: list[Any] = []
    for _ in range(5000):
        deep = [deep]
    assert len(brief(deep)) < 40 and len(brief("x" * 10**6)) < 60


def test_a_garbage_hello_reply_is_refused_as_such_not_as_no_answer() -> None:
    """'no answer on its hello key' although an answer came (issue 29): the refusal says what came."""
    from supervisor.engine.startup import check_hello
    from supervisor.errors import ScenarioError

    try:
        read_hello(b"\x91" * 100 + b"\x01")
    except ValueError as exc:
        refused = exc
    with pytest.raises(ScenarioError, match=r"vehicle 2 answered on its hello key with what is not a hello \(too deep"):
        check_hello("vehicle 2", {}, refused)

"""A vehicle's step message and the broker's link events read straight from their msgpack payload into typed records,
in one pass of msgspec in C, and each record's log form from them: the supervisor's intake reads ~18 records a step.

The state and the link events are their records themselves (comms.records.state.StateReport,
comms.records.records.LinkEvent, each its message's only description); the others are structs of the records'
(comms.records.records.Transmission, comms.records.receptions.RxBatch) with the same msgspec checks
(comms.records.fields.converted: the same annotations; held together by tests/test_bus_records.py), in the order of the
record's `to_message`, so that the log form `log_json` is the bytes orjson writes for `to_message()`. What the types
cannot say (a vehicle owning its key, a rotation, a speed) is the caller's to check, as `from_message` does. A payload
msgspec refuses reads as None here: the caller then reads it the slow way (comms.records.messages.decode and the
records' from_message), which says what is wrong or, in the few cases msgspec is stricter, accepts it; so what these
readings accept, the slow way accepts as the same records.
"""

from __future__ import annotations

from typing import Any

import msgspec
import orjson

from comms.records.fields import Finite
from comms.records.receptions import RxBatch
from comms.records.records import LinkEvent, Transmission
from comms.records.state import StateReport


class PartsWire(msgspec.Struct):
    """What a step message carries besides its state (comms.records.messages.step_message): an earlier step's."""

    tx: Transmission | None = None
    rx: RxBatch | None = None


class StepWire(PartsWire):
    """... and a window's last step's: the window's earlier steps (each read as one step) and next_tx."""

    next_tx: int | None = None
    earlier: list[msgspec.Raw] | None = None


class EventsWire(msgspec.Struct):
    """comms.records.events.LinkEvents as its message has it."""

    t: Finite
    k: int
    events: list[LinkEvent]


class Step(msgspec.Struct):
    """One step of a vehicle's step message, read."""

    state: StateReport
    tx: Transmission | None
    rx: RxBatch | None


_STATE = msgspec.msgpack.Decoder(StateReport)
_STEP = msgspec.msgpack.Decoder(StepWire)
_PARTS = msgspec.msgpack.Decoder(PartsWire)
_EVENTS = msgspec.msgpack.Decoder(EventsWire)
_MSGSPEC_REFUSES = (msgspec.DecodeError, msgspec.ValidationError)


def read_window(payload: bytes) -> tuple[list[Step], int | None] | None:
    """(the steps of a vehicle's step message, in order, the last its own; its next_tx) or None where msgspec
    refuses any of it (then every part is read the slow way: comms.records.messages.split_window and split_step)."""
    try:
        last = _STEP.decode(payload)
        steps = [_step(raw, _PARTS.decode(raw)) for raw in last.earlier or ()]
        steps.append(_step(payload, last))
    except _MSGSPEC_REFUSES:
        return None
    return steps, last.next_tx


def _step(payload: bytes | msgspec.Raw, parts: PartsWire) -> Step:
    """A step of the message (an earlier step's own earlier steps and next_tx are not read: split_window)."""
    return Step(_STATE.decode(payload), parts.tx, parts.rx)


def read_events(payload: bytes) -> EventsWire | None:
    """The link events of a cpf/comms/events message, or None where msgspec refuses any of it (comms.records.events)."""
    try:
        return _EVENTS.decode(payload)
    except _MSGSPEC_REFUSES:
        return None


def log_json(record: StateReport | Transmission | RxBatch | LinkEvent) -> bytes:
    """The record's log form: what orjson writes for its record's to_message() (supervisor.record.recorder)."""
    message: dict[str, Any] = msgspec.to_builtins(record)
    return orjson.dumps(message)

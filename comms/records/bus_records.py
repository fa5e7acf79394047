"""A vehicle's step message and the broker's link events read straight from their msgpack payload into typed records,
in one pass of msgspec in C, and each record's log form from them: the supervisor's intake reads ~18 records a step,
and the broker reads the step messages here too (comms.broker.step_reading), so that both take the same ones. The
broker's batches message is read here for the vehicles (read_batches): its tick and the vehicle's own receptions.

The parts are their records themselves, each its message's only description (comms.records.state.StateReport,
comms.records.records.Transmission, comms.records.receptions.RxBatch, comms.records.events.LinkEvents), so that the
log form `log_json` is the bytes orjson writes for `to_message()`. What the types cannot say (a vehicle owning its
key, a rotation, a speed) is the caller's to check, as `from_message` does (each record's check()). A payload msgspec
refuses reads as None here: the caller then reads it the slow way (comms.records.messages.decode and the records'
from_message), which says what is wrong (an older log's form aside, the same types refuse the same messages). One
difference, the same for every reader since each reads here first: msgspec skips a field no record has without
looking into it, so a value nested deeper than the bounded reader takes, map keys of other types or text that is
not UTF-8 there pass here, where the slow reading refuses the message (nothing reads that field either way; a value
nested near the interpreter's recursion limit, ~1000 levels, is refused at a depth that depends on the caller's).
"""

from __future__ import annotations

from typing import Any

import msgspec
import orjson

from comms.records.bounded import MAX_BYTES
from comms.records.events import LinkEvents
from comms.records.receptions import Delivery, RxBatch
from comms.records.records import LinkEvent, Transmission
from comms.records.state import StateReport
from comms.records.tick import Tick


class PartsWire(msgspec.Struct):
    """What a step message carries besides its state (comms.records.messages.step_message): an earlier step's."""

    tx: Transmission | None = None
    rx: RxBatch | None = None


class StepWire(PartsWire):
    """... and a window's last step's: the window's earlier steps (each read as one step) and next_tx."""

    next_tx: int | None = None
    earlier: list[msgspec.Raw] | None = None


class Step(msgspec.Struct):
    """One step of a vehicle's step message, read."""

    state: StateReport
    tx: Transmission | None
    rx: RxBatch | None


class BatchesWire(msgspec.Struct):
    """The broker's batches message as a vehicle reads it (comms.records.messages.batches_message): the tick and each
    vehicle's receptions, packed on their own (None: the broker is down)."""

    tick: Tick
    rx: dict[int, bytes] | None = None


_STATE = msgspec.msgpack.Decoder(StateReport)
_STEP = msgspec.msgpack.Decoder(StepWire)
_PARTS = msgspec.msgpack.Decoder(PartsWire)
_EVENTS = msgspec.msgpack.Decoder(LinkEvents)
_BATCHES = msgspec.msgpack.Decoder(BatchesWire)
_STEP_RECEPTIONS = msgspec.msgpack.Decoder(list[Delivery])  # a tick of one step: its receptions
_WINDOW_RECEPTIONS = msgspec.msgpack.Decoder(list[list[Delivery]])  # a tick of a window: a list per step
# What msgspec raises for a payload it will not read; RecursionError: its skipping of a deep value it does not keep
# (an unknown field, an earlier step) counts its depth against the interpreter's limit. The bounded reader then
# reads the payload again and names the cause (comms.records.bounded).
_MSGSPEC_REFUSES = (msgspec.DecodeError, msgspec.ValidationError, RecursionError)


def read_window(payload: bytes) -> tuple[list[Step], int | None] | None:
    """(the steps of a vehicle's step message, in order, the last its own; its next_tx) or None where msgspec
    refuses any of it, or it is larger than the bounded reader takes (then every part is read the slow way:
    comms.records.messages.split_window and split_step)."""
    if len(payload) > MAX_BYTES:
        return None
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


def read_events(payload: bytes) -> LinkEvents | None:
    """The link events of a cpf/comms/events message, or None where msgspec refuses any of it (comms.records.events)."""
    if len(payload) > MAX_BYTES:
        return None
    try:
        return _EVENTS.decode(payload)
    except _MSGSPEC_REFUSES:
        return None


def read_batches(payload: bytes, vid: int, dt: float) -> tuple[Tick, list[RxBatch] | None] | None:
    """(the tick, vehicle vid's reception batch of each step of its window: step j's at t = j dt, the first at the
    tick's own t; None if the broker is down) of a batches message, or None where msgspec refuses any of it, the
    tick is not one (Tick.check) or the receptions are not one list per step (the vehicle then reads it the slow way,
    comms.records.messages.parse_window, which says what is wrong). Only vid's receptions are unpacked."""
    if len(payload) > MAX_BYTES:
        return None
    try:
        wire = _BATCHES.decode(payload)
        tick = wire.tick.check()
        if wire.rx is None:
            return tick, None
        packed, steps = wire.rx.get(vid), tick.end - tick.k
        if steps == 1:
            mine = [] if packed is None else _STEP_RECEPTIONS.decode(packed)
            return tick, [RxBatch(tick.t, tick.k, vid, tuple(mine))]
        per_step = [[] for _ in range(steps)] if packed is None else _WINDOW_RECEPTIONS.decode(packed)
    except (*_MSGSPEC_REFUSES, ValueError):  # ValueError: Tick.check's
        return None
    if len(per_step) != steps:
        return None
    times = [tick.t, *(j * dt for j in range(tick.k + 1, tick.end))]
    return tick, [
        RxBatch(t, j, vid, tuple(d)) for j, t, d in zip(range(tick.k, tick.end), times, per_step, strict=True)
    ]


def log_json(record: StateReport | Transmission | RxBatch | LinkEvent | LinkEvents) -> bytes:
    """The record's log form: what orjson writes for its record's to_message() (supervisor.record.recorder)."""
    message: dict[str, Any] = msgspec.to_builtins(record)
    return orjson.dumps(message)

"""The broker's reading of a vehicle's step message: as the supervisor's intake reads it (supervisor.engine.intake),
straight from its msgpack payload into typed records in one pass of msgspec (comms.records.bus_records.read_window),
and the slow way (the bounded reader, then each record's from_message) only where msgspec refuses it, to say what is
wrong. Each step message is read by the broker and the supervisor alike (in lockstep and realtime runs), so both
take the same ones: what one filed and the other dropped would put on the channel a state the log never had.

A malformed step message is a ValueError (dropped whole); a malformed transmission in a good one is kept as its error,
for the broker to count when it files the step (the state still counts).
"""

from __future__ import annotations

from dataclasses import dataclass

from comms.records.bounded import brief
from comms.records.bus_records import read_window
from comms.records.fields import is_int
from comms.records.messages import Message, decode, parse_tx, split_window
from comms.records.records import Transmission
from comms.records.state import StateReport


@dataclass(frozen=True, slots=True)
class VehicleStep:
    """One step of a vehicle's step message, read: its state (checked: the vehicle owns the key) and its
    transmission, key-checked, or the ValueError it did not read with."""

    report: StateReport
    tx: Transmission | None
    tx_error: ValueError | None = None


def read_steps(payload: bytes, vid: int, whole: bool) -> tuple[list[VehicleStep], int | None, int]:
    """(the steps of vehicle vid's step message, in order, the last its own; the first step at which it may transmit
    next, None if it does not say; the message's first step); whole: every step of a window, else only the last (the
    earlier ones are needed only for a window run past transmissions: comms.broker.lookahead), the first step's
    number read all the same, unchecked but for its type (each step once, in order: comms.records.stream).
    ValueError for a message dropped whole."""
    window = read_window(payload)
    if window is None:
        return _read_slowly(payload, vid, whole)
    steps, next_tx = window
    states = [step.state.check(vid) for step in (steps if whole else steps[-1:])]
    read = [_typed(state, step.tx, vid) for state, step in zip(states, steps[-len(states) :], strict=True)]
    return read, next_tx, steps[0].state.k


def _typed(report: StateReport, tx: Transmission | None, vid: int) -> VehicleStep:
    if tx is None:
        return VehicleStep(report, None)
    try:
        return VehicleStep(report, tx.check(vid))
    except ValueError as exc:
        return VehicleStep(report, None, exc)


def _read_slowly(payload: bytes, vid: int, whole: bool) -> tuple[list[VehicleStep], int | None, int]:
    """read_steps through the bounded reader and the records' from_message: the message checked whole as read_window
    would (a malformed next_tx or earlier step drops it), the earlier steps' states read only if whole (the first
    step's number all the same)."""
    steps, next_tx = split_window(decode(payload))
    first = steps[0].get("k")
    if not isinstance(first, int) or not is_int(first):  # read_window's type for it
        raise ValueError(f"field 'k' of the message's first step is not a step, got {brief(first)}")
    if not whole:
        steps = steps[-1:]
    reports = [StateReport.from_message(step, vid) for step in steps]
    return [_slow_step(step, report, vid) for step, report in zip(steps, reports, strict=True)], next_tx, first


def _slow_step(message: Message, report: StateReport, vid: int) -> VehicleStep:
    tx = message.get("tx")
    if tx is None:
        return VehicleStep(report, None)
    try:
        if not isinstance(tx, dict):
            raise ValueError("field 'tx' is not a map")
        return VehicleStep(report, parse_tx(tx, vid))
    except ValueError as exc:
        return VehicleStep(report, None, exc)

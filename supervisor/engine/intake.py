"""What the Zenoh supervisor takes in from the bus: every message recorded as the log keeps it, the vehicles' states
counted by step (the clock waits on them), and the broker's link events booked in the supervisor's own books.

A malformed message is counted and dropped, never fatal: the run reports how many there were at its end.
"""

from __future__ import annotations

import contextlib

from comms.bus import Publishers, Received, decode_or_none
from comms.messages import (
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_EVENTS_KEY,
    Message,
    event_message,
    parse_event,
    parse_events,
    rx_key,
    split_step,
    state_key,
    tx_key,
    vehicle_of_key,
)
from comms.state import StateReport
from supervisor.analysis.series import SeriesBuilder
from supervisor.config.derived import steps_of
from supervisor.config.fleet import link_stats
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.books import LinkBooks
from supervisor.engine.realtime_timing import RealtimeTiming
from supervisor.record.recorder import Recorder


class Intake:
    """The supervisor's record of the run: the log, the series for the summary, the books of the links."""

    def __init__(self, sc: Scenario, rec: Recorder, timing: RealtimeTiming | None) -> None:
        self.rec = rec
        self.builder = SeriesBuilder(sc.vehicle_ids, steps_of(sc), sc.scenario.step)
        self.books = LinkBooks(link_stats(sc))
        self.timing = timing  # realtime runs: how well they keep to the wall clock
        self.states: dict[int, set[int]] = {}  # k -> vehicles whose state arrived
        self.last_state: dict[int, Message] = {}  # a restarted vehicle resumes from it
        self.last_seq: dict[int, int] = {}  # ... and numbers its transmissions on from this
        self.done: Message | None = None  # the current broker's end-of-run report
        self.broker_events = 0  # link events published by the current broker
        self.malformed = 0

    def take(self, item: Received, t: float) -> None:
        """One message from the bus; t: the supervisor's time, for a message that carries none."""
        message = decode_or_none(item.payload)
        if message is None:
            self.malformed += 1
            return
        owned = vehicle_of_key(item.key)
        if owned is not None and owned[1] == "state":
            self._step(owned[0], message, t)
        elif item.key == COMMS_EVENTS_KEY:
            self._events(message, t)
        else:
            self.write(item.key, message, t)
            if item.key == COMMS_DONE_KEY:
                self.done = message

    def write(self, key: str, message: Message, t: float) -> None:
        stamp = message.get("t")
        self.rec.write(key, stamp if isinstance(stamp, int | float) else t, message)

    def publish(self, pubs: Publishers, key: str, t: float, message: Message) -> None:
        """What the supervisor says on the bus is recorded as it says it."""
        pubs.put(key, message)
        self.rec.write(key, t, message)

    def stepped(self, k: int, alive: list[int]) -> bool:
        """Whether every vehicle in `alive` reported its state of step k."""
        return all(v in self.states.get(k, ()) for v in alive)

    def broker_started(self) -> None:
        """A new broker: its report and event count start afresh (the books go on)."""
        self.broker_events, self.done = 0, None

    def books_closed(self) -> bool:
        """The broker's end-of-run report is in, and every event it announced with it."""
        return self.done is not None and self.broker_events >= int(self.done.get("events", 0))

    def close_open(self, t: float, reason: str) -> None:
        """Close every packet still open in the books (its broker is gone, or the run ended), on the record."""
        events = self.books.close_open(t, reason)
        self.books.add(events)
        for event in events:
            self.rec.write(COMMS_EVENT_KEY, event.t, event_message(event))

    def _step(self, vid: int, message: Message, t: float) -> None:
        """A vehicle's step message, recorded as the log keeps it: reception batch, transmission, state."""
        state, tx, rx = split_step(message)
        if self.timing is not None:
            self.timing.add_state(state)
            if rx is not None:
                self.timing.add_rx(rx)
        if rx is not None:
            self.write(rx_key(vid), rx, t)
        if tx is not None:
            self.write(tx_key(vid), tx, t)
        self.write(state_key(vid), state, t)
        with contextlib.suppress(ValueError):  # a malformed state is on the record, but not booked
            self._state(StateReport.from_message(state, vid), state)

    def _state(self, report: StateReport, message: Message) -> None:
        self.builder.add(message)
        self.states.setdefault(report.k, set()).add(report.vehicle)
        self.last_state[report.vehicle] = message
        if report.tx_seq:
            self.last_seq[report.vehicle] = report.tx_seq

    def _events(self, batch: Message, t: float) -> None:
        """A step's link events: one log record each; a malformed one is recorded but not booked."""
        try:
            events = parse_events(batch)
        except ValueError:
            self.malformed += 1
            return
        self.broker_events += len(events)
        booked = []
        for message in events:
            self.write(COMMS_EVENT_KEY, message, t)
            with contextlib.suppress(ValueError):
                booked.append(parse_event(message))
        self.books.add(booked)

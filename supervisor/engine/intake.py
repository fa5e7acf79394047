"""What the Zenoh supervisor takes in from the bus: every message read through its record (comms.records.state,
comms.records.records, comms.records.receptions, comms.channel.channel, comms.records.reports) and checked against the
run, then recorded in the record's own form; the vehicles' states counted by step (the clock waits on them), and the
broker's link events booked in the supervisor's own books.

A message that does not read as its record, or does not fit the run (a step or a time outside it, a time that is not
its step's, a vehicle or a link the run does not have), is counted by its key and dropped, never recorded and never
fatal: the run reports the counts at its end, with those the broker and the vehicles report (`reports`).
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from typing import TypeVar

from comms.broker.windows import report_of
from comms.bus.bus import Publishers, Received
from comms.records import reports
from comms.records.bounded import cause_of, dropped
from comms.records.bus_records import Step, log_json, read_events, read_window
from comms.records.drops import Drops
from comms.records.events import LinkEvents
from comms.records.messages import (
    COMMS_DONE_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    Message,
    decode,
    rx_key,
    split_step,
    split_window,
    state_key,
    tx_key,
    vehicle_done_key,
    vehicle_of_key,
)
from comms.records.receptions import RxBatch
from comms.records.records import LinkEvent, Transmission
from comms.records.reports import SUPERVISOR, BusDrops, CommsDone, CommsStats, SupervisorDone, VehicleDone
from comms.records.state import StateReport
from comms.records.stream import FAULTY, VEHICLE_FAULTS, at_step_time, in_stream
from supervisor.analysis.series import SeriesBuilder
from supervisor.config.derived import steps_of
from supervisor.config.fleet import link_stats
from supervisor.config.plausibility import plausibility
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.books import LinkBooks
from supervisor.engine.realtime_timing import RealtimeTiming
from supervisor.engine.run_bounds import RunBounds
from supervisor.record.recorder import Recorder

log = logging.getLogger("cpf.engine")
T = TypeVar("T")


class Intake:
    """The supervisor's record of the run: the log, the series for the summary, the books of the links."""

    def __init__(self, sc: Scenario, rec: Recorder, timing: RealtimeTiming | None) -> None:
        self.rec = rec
        self.bounds = RunBounds.of(sc)
        self.builder = SeriesBuilder(sc.vehicle_ids, steps_of(sc), sc.scenario.step)
        self.books = LinkBooks(link_stats(sc))
        self.timing = timing  # realtime runs: how well they keep to the wall clock
        self.states: dict[int, set[int]] = {}  # k -> vehicles whose state arrived
        self.last_report: dict[int, StateReport] = {}  # a restarted vehicle resumes from it (last_state)
        self.last_seq: dict[int, int] = {}  # ... and numbers its transmissions on from this
        self.next_tx: dict[int, tuple[int, int]] = {}  # vehicle -> (latest step, first step it may transmit at)
        self.taken: dict[int, int] = {}  # vehicle -> its latest step taken: each step once, in order (in_stream)
        self.plausible = plausibility(sc)  # vehicle -> its bounds (comms.records.plausible)
        self.granted: int | None = None  # the first step the clock has not granted yet (None: none granted)
        self.faulty: dict[int, str] = {}  # vehicle -> why its state was its fault (not finite, implausible)
        self.faults_told: set[int] = set()  # ... those the supervisor has acted on
        self.done: CommsDone | None = None  # the current broker's end-of-run report
        self.broker_events = 0  # link events published by the current broker
        # steps' times, with the vehicles alive then, whose lambda_2 waits for their deliveries (window)
        self.windows: deque[tuple[float, tuple[int, ...]]] = deque()
        self.events_t = -math.inf  # the latest link events message's time: every delivery up to it is booked
        self.drops = Drops(log, SUPERVISOR, logging.DEBUG)  # what the supervisor dropped, by key and by cause
        self.malformed = self.drops.by_key  # key -> messages the supervisor dropped
        self.vehicles_done: dict[int, VehicleDone] = {}  # each vehicle's end-of-run report

    def take(self, item: Received, t: float) -> None:
        """One message from the bus (t: the supervisor's time, unused: every message recorded carries its own).
        Anything that does not read as its record or does not fit the run is counted and dropped."""
        try:
            if not self._typed(item.key, item.payload):
                self._take(item.key, decode(item.payload))
        except (ValueError, RecursionError) as exc:  # RecursionError: never past the bounded reader, counted if so
            self.drops.drop(item.key, exc)
            owned = vehicle_of_key(item.key)
            if owned is not None and owned[1] == "state" and cause_of(exc) in VEHICLE_FAULTS:
                self._fault(owned[0], item.payload, exc)

    def _fault(self, vid: int, payload: bytes, exc: BaseException) -> None:
        """A state not finite or implausible is its vehicle's fault if it was its next step (a copy of an older
        one, from whoever holds its credential, is only a replay: counted and dropped)."""
        with contextlib.suppress(ValueError):
            k = decode(payload).get("k")
            if isinstance(k, int) and self.taken.get(vid, -1) < k < self.bounds.steps:
                self.faulty.setdefault(vid, f"{cause_of(exc)}: {exc}")

    def expect(self, vid: int, k: int) -> None:
        """Vehicle vid's next step is k (each one's first, a restarted one's; until told, any first step is taken)."""
        self.taken[vid] = k - 1

    def new_faults(self) -> list[tuple[int, str]]:
        """(vehicle, why) of each vehicle whose state was its fault since the last call: the run decides
        (scenario.on_vehicle_loss)."""
        new = [(vid, why) for vid, why in self.faulty.items() if vid not in self.faults_told]
        self.faults_told.update(vid for vid, _ in new)
        return new

    def waiting_for(self, k: int, alive: list[int]) -> str:
        """What a stall waits for: each vehicle whose state of step k is missing, and why its latest message on its
        state key was dropped, if one was."""
        missing = [v for v in alive if v not in self.states.get(k, ())]
        said = [f"vehicle {v}" + self._last_drop(v) for v in missing]
        return f"the state of step {k} of {', '.join(said) if said else 'every vehicle'}"

    def _last_drop(self, vid: int) -> str:
        why = self.drops.last.get(state_key(vid))
        return "" if why is None else f" (its latest message was dropped: {why})"

    def _take(self, key: str, message: Message) -> None:
        owned = vehicle_of_key(key)
        if owned is not None and owned[1] == "state":
            self._window(owned[0], message)
        elif owned is not None and owned[1] == "done":
            self._vehicle_done(owned[0], message)
        elif key == COMMS_EVENTS_KEY:
            self._events(message)
        elif key == COMMS_STATS_KEY:
            self._stats(message)
        elif key == COMMS_DONE_KEY:
            self._comms_done(message)
        else:
            raise ValueError("not a key the supervisor reads")

    def _typed(self, key: str, payload: bytes) -> bool:
        """A vehicle's step message or the broker's link events read straight into typed records
        (comms.records.bus_records: ~2x faster) and checked and recorded as _take would; False, with nothing done, for
        any message msgspec refuses (or any other key): _take then reads it and says what is wrong."""
        if key == COMMS_EVENTS_KEY:
            events = read_events(payload)
            if events is not None:
                self._typed_events(events)
            return events is not None
        owned = vehicle_of_key(key)
        window = read_window(payload) if owned is not None and owned[1] == "state" else None
        if owned is None or window is None:
            return False
        steps, next_tx = window
        self.bounds.vehicle(owned[0])
        for step in steps:
            self._typed_step(owned[0], step)
        self._next(owned[0], steps[-1].state.k, next_tx)
        return True

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
        return self.done is not None and self.broker_events >= self.done.events

    def window(self, t: float, alive: Sequence[int]) -> None:
        """A step at t is done: the books' window for it (LinkBooks.window) once every delivery up to t is booked.
        The broker publishes a step's link events after the batches the vehicles step on (off their critical path),
        so they may come after the step's states: the window waits for the first events message at or after t (a
        delivery comes in the message of its own step), or the end of the run (close_windows)."""
        self.windows.append((t, tuple(alive)))
        self._run_windows()

    def close_windows(self) -> None:
        """Every window still waiting: at the end, every event is in."""
        self.events_t = math.inf
        self._run_windows()

    def _run_windows(self) -> None:
        while self.windows and self.windows[0][0] <= self.events_t + 1e-9:
            self.books.window(*self.windows.popleft())

    def close_open(self, t: float, reason: str) -> None:
        """Close every packet still open in the books (its broker is gone, or the run ended), on the record."""
        events = self.books.close_open(t, reason)
        self.books.add(events)
        if events:  # one batch at t, of its step (the in-process engine's too)
            self.rec.write(COMMS_EVENTS_KEY, t, LinkEvents(t, round(t / self.bounds.dt), tuple(events)).to_message())

    def own_done(self, t: float) -> SupervisorDone:
        """The supervisor's end-of-run report at t: what it dropped (the log keeps it for `cpf report`)."""
        return SupervisorDone(t, round(t / self.bounds.dt), *self.drops.reported())

    def bus_drops(self) -> BusDrops:
        """What every reader dropped: the supervisor's own, each report that came (the broker's latest), or None."""
        expected = reports.bus_readers(sorted(self.bounds.vehicles))
        return reports.bus_drops(self.own_done(0.0), self.done, self.vehicles_done, expected)

    def _window(self, vid: int, message: Message) -> None:
        """A vehicle's step message, of one step or of a lockstep time window: each step's records, in order, as
        one step at a time writes them; and the first step at which it may transmit next (the clock's windows)."""
        steps, next_tx = split_window(message)
        self.bounds.vehicle(vid)  # the key's: once for the window's steps
        for step in steps:
            self._step(vid, step)
        self._next(vid, int(steps[-1]["k"]), next_tx)

    def _next(self, vid: int, last: int, next_tx: int | None) -> None:
        """Vehicle vid's latest step, and the first at which it may transmit next."""
        if vid not in self.next_tx or self.next_tx[vid][0] < last:  # one that says nothing may transmit at once
            self.next_tx[vid] = report_of(last, next_tx)

    def _step(self, vid: int, message: Message) -> None:
        """A vehicle's step message: its state, and the transmission and reception batch it carries, each read
        through its record and recorded as the record writes it. A bad state drops the whole message; a bad
        transmission or batch only itself (counted), as the broker does."""
        raw, tx, rx = split_step(message)
        state = StateReport.from_message(raw, vid)
        self._next_of(state)
        self.bounds.step(state.k, state.t)
        self._in_stream(state)
        for held in state.estimate_age:
            self.bounds.vehicle(held.vehicle)
        transmission = self._part(tx_key(vid), lambda: self._tx(tx, vid, state)) if tx is not None else None
        batch = self._part(rx_key(vid), lambda: self._rx(rx, vid)) if rx is not None else None
        message = state.to_message()
        if self.timing is not None:
            self.timing.add(state, batch)
        if batch is not None:
            self.rec.write(rx_key(vid), batch.t, batch.to_message())
        if transmission is not None:
            self.rec.write(tx_key(vid), transmission.t, transmission.to_message())
        self.rec.write(state_key(vid), state.t, message)
        self._book(state)

    def _typed_step(self, vid: int, step: Step) -> None:
        """_step of a step read by msgspec: the checks its types cannot say (StateReport.from_message's, then
        _step's, in _step's order), and the records written in their log form straight from the typed ones."""
        state = step.state.check(vid)
        self._next_of(state)
        self.bounds.step(state.k, state.t)
        self._in_stream(state)
        for held in state.estimate_age:
            self.bounds.vehicle(held.vehicle)
        tx, rx = step.tx, step.rx
        transmission = self._part(tx_key(vid), lambda: self._typed_tx(tx, vid, state)) if tx is not None else None
        batch = self._part(rx_key(vid), lambda: self._fitting_rx(rx, vid)) if rx is not None else None
        if self.timing is not None:
            self.timing.add(state, batch)
        if batch is not None:
            self.rec.write_json(rx_key(vid), batch.t, log_json(batch))
        if transmission is not None:
            self.rec.write_json(tx_key(vid), transmission.t, log_json(transmission))
        self.rec.write_state(state_key(vid), state.t, log_json(state), state)
        self._book(state)

    def _next_of(self, state: StateReport) -> None:
        """ValueError (dropped) unless the state is its vehicle's next step (comms.records.stream: no replay is
        recorded), from a vehicle not yet found faulty: before the run's bounds, so that a step far beyond the clock
        is named as the broker names it, 'beyond the window' (it was 'malformed' here)."""
        vid = state.vehicle
        if vid in self.faulty:
            raise dropped(FAULTY, f"vehicle {vid} sent a state that was its fault before ({self.faulty[vid]})")
        in_stream(state.k, self.taken.get(vid), self.granted)

    def _in_stream(self, state: StateReport) -> None:
        """Taken as its vehicle's next step (_next_of: checked) if plausible (comms.records.plausible)."""
        vid = state.vehicle
        bounds = self.plausible.get(vid)
        if bounds is not None:
            bounds.check(state, self.last_report.get(vid), self.bounds.dt)
        self.taken[vid] = state.k

    def _typed_tx(self, tx: Transmission, vid: int, state: StateReport) -> Transmission:
        tx.check(vid)
        at_step_time(tx.t, state.k, self.bounds.dt, "the transmission's")  # the channel times its packet from t
        self.plausible[vid].check_tx(tx, state, self.bounds.dt)  # (vid: the state's, one of the run's: plausible)
        return tx

    def _part(self, key: str, read: Callable[[], T]) -> T | None:
        """A step message's transmission or reception batch, read; None (counted on key) if it does not read."""
        try:
            return read()
        except ValueError as exc:
            self.drops.drop(key, exc, "part of a step message")
            return None

    def _tx(self, message: Message, vid: int, state: StateReport) -> Transmission:
        return self._typed_tx(Transmission.from_message(message, vid), vid, state)

    def _rx(self, message: Message, vid: int) -> RxBatch:
        return self._fitting_rx(RxBatch.from_message(message), vid)

    def _fitting_rx(self, batch: RxBatch, vid: int) -> RxBatch:
        """A reception batch (read either way) that fits vehicle vid's step in the run; ValueError if not."""
        if batch.vehicle != vid:
            raise ValueError(f"vehicle {batch.vehicle}'s receptions in vehicle {vid}'s step")
        self.bounds.time(batch.t, "the batch's")
        for d in batch.receptions:
            self.bounds.link(d.sender, vid)
        return batch

    def _book(self, report: StateReport) -> None:
        self.builder.add(report)
        self.states.setdefault(report.k, set()).add(report.vehicle)
        self.last_report[report.vehicle] = report
        if report.tx_seq:
            self.last_seq[report.vehicle] = report.tx_seq

    @property
    def last_state(self) -> dict[int, Message]:
        """Each vehicle's last state, as recorded: a restarted vehicle resumes from it."""
        return {vid: report.to_message() for vid, report in self.last_report.items()}

    def _events(self, batch: Message) -> None:
        """A step's link events: one log record (cpf/comms/events). The batch counts as the broker announced it (its
        report says how many it published); an event that does not read or fit is counted and dropped."""
        unread: list[ValueError] = []
        events = LinkEvents.from_message(batch, unread)
        self.bounds.time(events.t, "the batch's")
        if not 0 <= events.k <= self.bounds.steps:
            raise ValueError("the batch's step is outside the run")
        self.broker_events += len(events.events) + len(unread)
        for exc in unread:  # a key gets an entry only for what was dropped on it
            self.drops.drop(COMMS_EVENTS_KEY, exc, "link event")
        booked = self._checked_events(events.events)  # one record, as the batch came but for the events dropped
        if booked:
            self.rec.write(COMMS_EVENTS_KEY, events.t, LinkEvents(events.t, events.k, tuple(booked)).to_message())
        self.books.add(booked)
        self._events_in(events.t)

    def _typed_events(self, batch: LinkEvents) -> None:
        """_events of a batch read by msgspec (every event read)."""
        self.bounds.time(batch.t, "the batch's")
        if not 0 <= batch.k <= self.bounds.steps:
            raise ValueError("the batch's step is outside the run")
        self.broker_events += len(batch.events)
        booked = self._checked_events(batch.events)
        if booked:
            kept = LinkEvents(batch.t, batch.k, tuple(booked))
            self.rec.write_events(COMMS_EVENTS_KEY, batch.t, log_json(kept), kept.events)
        self.books.add(booked)
        self._events_in(batch.t)

    def _events_in(self, t: float) -> None:
        """The broker's events of the step at t are booked: the windows up to it can be taken."""
        self.events_t = max(self.events_t, t)
        self._run_windows()

    def _checked_events(self, events: Iterable[LinkEvent]) -> list[LinkEvent]:
        """The events that fit the run; the others counted and dropped."""
        booked: list[LinkEvent] = []
        for event in events:
            try:
                booked.append(self._event(event))
            except ValueError as exc:
                self.drops.drop(COMMS_EVENTS_KEY, exc, "link event")
        return booked

    def _event(self, event: LinkEvent) -> LinkEvent:
        self.bounds.time(event.t, "the event's")
        self.bounds.link(event.sender, event.receiver)
        if event.seq < 0 or (event.delay is not None and event.delay < 0):
            raise ValueError("a negative sequence number or delay")
        return event

    def _stats(self, message: Message) -> None:
        stats = CommsStats.from_message(message)
        self.bounds.time(stats.t, "the statistics'")
        for link in stats.links:
            self.bounds.link(link.sender, link.receiver)
        self.rec.write(COMMS_STATS_KEY, stats.t, stats.to_message())

    def _comms_done(self, message: Message) -> None:
        done = CommsDone.from_message(message)
        self.bounds.time(done.t, "the report's")
        self.rec.write(COMMS_DONE_KEY, done.t, done.to_message())
        self.done = done

    def _vehicle_done(self, vid: int, message: Message) -> None:
        self.bounds.vehicle(vid)
        done = VehicleDone.from_message(message, vid)
        self.bounds.time(done.t, "the report's")
        self.rec.write(vehicle_done_key(vid), done.t, done.to_message())
        self.vehicles_done[vid] = done

"""The log's records turned back into what a live run puts on the bus, for `cpf replay` (supervisor/tools/replay.py).

The log keeps some messages in another form than the bus carries them (README, "Key expressions and messages"): a
vehicle's step message is split into its rx, tx and state records, and the broker's cpf/comms/step (tick and every
vehicle's receptions) is not kept. `bus_form` undoes that, instant by instant of log time, so a subscriber written
against a replay works on a live run and the reverse:

- cpf/vehicle/<id>/state carries its `tx` and `rx` again (the step message), and the rx and tx records are not
  published on their own (a realtime run's broker does publish rx batches: those of a realtime log are);
- a step's link events (cpf/comms/events) go out as logged, the bus's form; an older log's single cpf/comms/event
  records go out as one cpf/comms/events message per step, at the next step instant after them, as the broker
  publishes them at the next tick;
- after each (not final) cpf/clock/tick, cpf/comms/step with the tick and each vehicle's receptions of that step
  (realtime: none, the vehicles take in their own deliveries).

`latched` gives what a subscriber joining at a later time needs first: the latest meta and graph, and the start of
every fault still in force.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Iterable, Iterator
from typing import Any

from comms.records.events import logged_events
from comms.records.messages import (
    COMMS_EVENT_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STEP_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    TICK_KEY,
    Message,
    encode_list,
    rx_key,
    step_message,
    vehicle_of_key,
)
from comms.records.receptions import RxBatch
from comms.records.run import FaultEvent
from comms.records.tick import Tick
from supervisor.record.meta import RunMeta

Record = tuple[str, int, Any]  # (topic, log time ns, message)
NS_PER_S = 1e9


def bus_form(records: Iterable[Record], meta: Message) -> Iterator[Record]:
    """The live bus's messages for records in log-time order (meta: the run's, read through its record for its
    step and clock). A log that is no cpf run (no meta that reads) is passed through as it is."""
    try:
        run = RunMeta.from_message(meta)
    except ValueError:
        yield from records
        return
    form = _BusForm(run.step, run.clock == "realtime")
    for stamp, group in itertools.groupby(records, key=lambda record: record[1]):
        yield from form.instant(stamp, list(group))
    yield from form.flush_events(None)


def latched(before: Iterable[Record]) -> list[Record]:
    """What a subscriber needs first when a replay starts after these records: the last meta, the last graph and
    the start of every fault that has not ended, in that order."""
    meta: Record | None = None
    graph: Record | None = None
    faults: dict[str, Record] = {}
    for record in before:
        topic, _, message = record
        if topic == META_KEY:
            meta = record
        elif topic == GRAPH_KEY:
            graph = record
        elif topic == FAULT_KEY and (event := _fault(message)) is not None:
            which = json.dumps([event.kind, event.detail], sort_keys=True)
            if event.phase == "start":
                faults[which] = record
            else:
                faults.pop(which, None)
    return [record for record in (meta, graph, *faults.values()) if record is not None]


def _fault(message: Any) -> FaultEvent | None:
    """The fault event a record holds, None if it does not read (it is replayed as it is, never latched)."""
    try:
        return FaultEvent.from_message(message) if isinstance(message, dict) else None
    except ValueError:
        return None


class _BusForm:
    def __init__(self, step: float, realtime: bool) -> None:
        self.step = step
        self.realtime = realtime
        self.events: list[Message] = []  # link events not yet published
        self.tx: dict[int, Message] = {}  # per vehicle, its transmission record waiting for its state
        self.rx: dict[int, Message] = {}  # per vehicle, its reception batch waiting for its state

    def instant(self, stamp: int, group: list[Record]) -> Iterator[Record]:
        """The bus messages of one instant of log time: the supervisor's, then the broker's, then the vehicles'."""
        k = self._step_of(stamp)
        ticked = False
        for topic, _, message in group:
            owned = vehicle_of_key(topic)
            if topic == COMMS_EVENT_KEY:
                continue
            if owned is not None and owned[1] in ("rx", "tx", "state"):
                continue
            if topic == TICK_KEY and k is not None and not ticked:
                yield topic, stamp, message
                yield from self._broker(stamp, k, message, group)
                ticked = True
                continue
            yield topic, stamp, message
        if k is not None and not ticked:  # a log without ticks (the in-process engine): events at the step instant
            yield from self.flush_events(stamp)
        yield from self._vehicles(stamp, group)
        self.events += [e for topic, _, m in group if topic == COMMS_EVENT_KEY for e in logged_events(topic, m)]

    def _broker(self, stamp: int, k: int, tick: Any, group: list[Record]) -> Iterator[Record]:
        yield from self.flush_events(stamp)
        try:
            read = Tick.from_message(tick) if isinstance(tick, dict) else None
        except ValueError:
            read = None
        if read is None or read.final:  # a tick that does not read gets no batches: no live broker would send them
            return
        batches: dict[int, bytes] = {}
        for topic, _, message in group:
            owned = vehicle_of_key(topic)
            if owned is not None and owned[1] == "rx" and (batch := _batch(message)) is not None and batch.k == k:
                batches[owned[0]] = encode_list(message["receptions"])  # as logged, once it reads
        rx = {} if self.realtime else (batches if read.comms else None)
        yield COMMS_STEP_KEY, stamp, {"t": read.t, "k": read.k, "tick": tick, "rx": rx}

    def _vehicles(self, stamp: int, group: list[Record]) -> Iterator[Record]:
        for topic, _, message in group:
            owned = vehicle_of_key(topic)
            if owned is None or not isinstance(message, dict):
                continue
            vehicle, leaf = owned
            if leaf == "tx":
                self.tx[vehicle] = message
            elif leaf == "rx":
                self.rx[vehicle] = message
                if self.realtime:  # the broker's deliveries, on the vehicle's rx key
                    yield rx_key(vehicle), stamp, message
            elif leaf == "state":  # one step at a time; next_tx as a live vehicle's, conservative: the next step
                tx, rx, k = self.tx.pop(vehicle, None), self.rx.pop(vehicle, None), message.get("k")
                yield topic, stamp, step_message(message, tx, rx, k + 1 if isinstance(k, int) else None)

    def flush_events(self, stamp: int | None) -> Iterator[Record]:
        """The events waiting, as one batch of the step at stamp (None: the end of the log, at their last time)."""
        if not self.events:
            return
        if stamp is None:
            stamp = round(max(float(e.get("t", 0.0)) for e in self.events) * NS_PER_S)
        k = round(stamp / NS_PER_S / self.step)
        yield COMMS_EVENTS_KEY, stamp, {"t": stamp / NS_PER_S, "k": k, "events": self.events}
        self.events = []

    def _step_of(self, stamp: int) -> int | None:
        """The step whose instant stamp is, if it is one."""
        k = round(stamp / NS_PER_S / self.step)
        return k if math.isclose(k * self.step, stamp / NS_PER_S, abs_tol=1e-9) else None


def _batch(message: Any) -> RxBatch | None:
    """The reception batch an rx record holds, None if it does not read (it is then not handed out again)."""
    try:
        return RxBatch.from_message(message) if isinstance(message, dict) else None
    except ValueError:
        return None

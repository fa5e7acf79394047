"""What the Foxglove scene needs of a run, taken from its cpf records as they are written (or read from a log).

Records go in one by one, in any order (the Zenoh supervisor gets the processes' messages as the bus delivers them):
everything kept is keyed by what the record says (vehicle, step, link, time), and where two records compete for one
place the larger wins by content, never the later, so the same records give the same history whatever their order.
Only what is shown is kept: the states of the published steps (every `every` steps), per directed link the last
outcome before each published instant, the faults and graphs. A record that does not read is skipped (an old or
damaged log); the run's own records always read.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from comms.records.events import EVENT_TOPICS, logged_events
from comms.records.messages import FAULT_KEY, GRAPH_KEY, META_KEY, vehicle_of_key
from comms.records.records import LinkEvent
from comms.records.run import FaultEvent, Graph
from comms.records.state import StateReport
from supervisor.record.meta import RunMeta

PUBLISH_PERIOD = 0.5  # s of simulated time between published instants (rounded to whole steps)
Float3 = tuple[float, float, float]
Link = tuple[int, int]
Outcome = tuple[float, int, str, str]  # (t, seq, kind, reason): a packet's fate on its link; compared as a whole


@dataclass(frozen=True, slots=True)
class Snapshot:
    """A vehicle at a published step: where it is, its attitude (R row-major), gamma, its virtual target, and what
    the plots show of it: gamma's rate and the path error's norm."""

    position: Float3
    rotation: tuple[float, ...]
    gamma: float
    target: Float3  # p_d(gamma) = position - error
    gamma_dot: float  # 1/s
    path_error: float  # m: |error| = |position - p_d(gamma)|


def publish_every(step: float) -> int:
    """Steps between published instants: PUBLISH_PERIOD in whole steps, at least one."""
    return max(1, round(PUBLISH_PERIOD / step))


@dataclass
class FleetHistory:
    """The run as the scene shows it. `take` every record; the run's meta first (nothing is kept before it)."""

    meta: RunMeta | None = None
    every: int = 1  # steps between published instants
    states: dict[int, dict[int, Snapshot]] = field(default_factory=dict)  # k -> vehicle -> snapshot
    outcomes: dict[tuple[Link, int], Outcome] = field(default_factory=dict)  # (link, published instant) -> last
    faults: list[FaultEvent] = field(default_factory=list)
    graphs: list[Graph] = field(default_factory=list)
    places: dict[int, int] = field(default_factory=dict)  # vehicle -> its place in the meta's fleet (its colour)
    _handlers: dict[str, Callable[[str, Any], None] | None] = field(default_factory=dict)

    def take(self, topic: str, message: Any) -> None:
        """One record of the log (topic, its message as JSON decodes it)."""
        if topic not in self._handlers:
            self._handlers[topic] = self._handler(topic)
        handler = self._handlers[topic]
        if handler is not None and isinstance(message, dict) and (self.meta is not None or topic == META_KEY):
            handler(topic, message)

    def _handler(self, topic: str) -> Callable[[str, Any], None] | None:
        owned = vehicle_of_key(topic)
        if owned is not None:
            return self._state if owned[1] == "state" else None
        if topic in EVENT_TOPICS:
            return self._events
        return {META_KEY: self._meta, FAULT_KEY: self._fault, GRAPH_KEY: self._graph}.get(topic)

    def _meta(self, _: str, message: Any) -> None:
        if self.meta is None:
            try:
                self.meta = RunMeta.from_message(message)
            except ValueError:
                return
            self.every = publish_every(self.meta.step)
            self.places = {vid: n for n, vid in enumerate(self.meta.vehicles)}

    def _state(self, topic: str, message: Any) -> None:
        k = message.get("k")
        if type(k) is not int or k % self.every:  # only the published steps are read (cheap for the others)
            return
        owned = vehicle_of_key(topic)
        try:
            report = StateReport.from_message(message, owned[0] if owned else -1)  # checked as it is read
        except ValueError:
            return
        self._keep(report)

    def take_state(self, report: StateReport) -> None:
        """A state record (the in-process engine's, or one the Zenoh supervisor read), on the published steps only:
        as `take` of its message for what the record's check() says (a NaN in a diagnostic: not shown); that its state
        itself is finite (t, position, attitude, velocities: what reading the message checks) is its writer's to
        see to (vehicles.step's sanity check, the Zenoh supervisor's reading)."""
        if self.meta is None or report.k % self.every:
            return
        try:
            report.check(report.vehicle)
        except ValueError:
            return
        self._keep(report)

    def _keep(self, report: StateReport) -> None:
        """A checked state of a published step kept as the scene shows it."""
        p, e = report.position, report.error
        target = (p[0] - e[0], p[1] - e[1], p[2] - e[2])
        norm = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])  # correctly rounded, in a fixed order: portable
        snapshot = Snapshot(p, report.rotation, report.gamma, target, report.gamma_dot, norm)
        self.states.setdefault(report.k, {})[report.vehicle] = snapshot

    def _events(self, topic: str, message: Any) -> None:
        """A record of link events: each at its own time (comms.records.events.logged_events)."""
        try:
            events = logged_events(topic, message)
        except ValueError:
            return
        for event in events:
            if isinstance(event, dict):
                self._event(event)

    def _event(self, message: Any) -> None:
        """A link event (comms.records.records.LinkEvent's wire form). Every event of a run passes here (32000 in the
        paper scenario): read by hand, for the fields kept, rather than through LinkEvent.from_message (3x the time)."""
        kind = message.get("kind")
        if kind != "delivered" and kind != "dropped":  # sent: a packet's fate is its delivery or its drop
            return
        t, sender, receiver, seq = message.get("t"), message.get("sender"), message.get("receiver"), message.get("seq")
        reason = message.get("reason") or ""
        if not (_number(t) and _integer(sender) and _integer(receiver) and _integer(seq) and isinstance(reason, str)):
            return
        self._outcome(sender, receiver, (float(t), seq, kind, reason))

    def take_event(self, event: LinkEvent) -> None:
        """A link event already read (and checked) by whoever wrote it: as `take` of its message."""
        if self.meta is not None and (event.kind == "delivered" or event.kind == "dropped"):
            self._outcome(event.sender, event.receiver, (event.t, event.seq, event.kind, event.reason or ""))

    def _outcome(self, sender: int, receiver: int, outcome: Outcome) -> None:
        """A packet's fate on its link: the last before each published instant is kept."""
        key = ((sender, receiver), self.instant_at_or_after(outcome[0]))
        if key not in self.outcomes or outcome > self.outcomes[key]:
            self.outcomes[key] = outcome

    def _fault(self, _: str, message: Any) -> None:
        try:
            self.faults.append(FaultEvent.from_message(message))
        except ValueError:
            return

    def _graph(self, _: str, message: Any) -> None:
        try:
            self.graphs.append(Graph.from_message(message))
        except ValueError:
            return

    def instant_at_or_after(self, t: float) -> int:
        """The first published step k (a multiple of `every`) whose time is not earlier than t: an arrival between
        two published instants shows at the next one."""
        assert self.meta is not None
        steps = t / self.meta.step
        k = round(steps) if abs(steps - round(steps)) < 1e-6 else math.ceil(steps)  # t_k, up to rounding: step k
        return -(-k // self.every) * self.every


def _number(value: object) -> bool:
    return (type(value) is float and math.isfinite(value)) or (type(value) is int and abs(value) < 2**53)


def _integer(value: object) -> bool:
    return type(value) is int

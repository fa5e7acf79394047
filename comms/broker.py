"""The acoustic-link broker process: every coordination message goes vehicle -> broker -> neighbour.

Thin Zenoh adapter around comms.broker_core. At tick k it waits until it holds every vehicle's state of step k-1 and
every transmission those states announce, then submits them to the channel and publishes step k's reception batches
and the per-packet link events. On the final tick it flushes the channel and reports how many events it published.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

from comms.broker_core import BrokerCore
from comms.bus import Handler, Publishers, decode_or_none, serve
from comms.channel import Kinematics, LinkEvent
from comms.messages import (
    COMMS_ALIVE,
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_STATS_KEY,
    ROOT,
    TICK_KEY,
    StateReport,
    Tick,
    event_message,
    parse_state,
    parse_tick,
    parse_tx,
    rx_key,
    rx_message,
    vehicle_of_key,
)
from vehicles.transmission import Transmission

log = logging.getLogger(__name__)


@dataclass
class _Books:
    """What has arrived, filed by step, until the step that needs it is handled."""

    ticks: dict[int, Tick] = field(default_factory=dict)
    states: dict[int, dict[int, StateReport]] = field(default_factory=dict)
    sent: dict[tuple[int, int], Transmission] = field(default_factory=dict)
    published: int = 0
    malformed: int = 0
    bad_tx: Counter[int] = field(default_factory=Counter)  # malformed transmissions per vehicle, not yet accounted


class Broker:
    def __init__(self, core: BrokerCore, vehicles: Sequence[int], publishers: Publishers, start_step: int = 0) -> None:
        self.core = core
        self.vehicles = list(vehicles)
        self.publishers = publishers
        self.books = _Books()
        self.next_k = start_step  # a restarted broker resumes mid-run, with nothing of the past in flight
        self.first = start_step
        self.previous: Tick | None = None  # the tick under which last step's transmissions were sent

    def take(self, key: str, payload: bytes) -> None:
        """File one incoming message; count and drop it if malformed or on a key its sender does not own."""
        message = decode_or_none(payload)
        owned = vehicle_of_key(key)
        try:
            if message is None:
                raise ValueError("undecodable")
            if key == TICK_KEY:
                tick = parse_tick(message)
                self.books.ticks[tick.k] = tick
            elif owned is not None and owned[1] == "state":
                report = parse_state(message, owned[0])
                self.books.states.setdefault(report.k, {})[report.vehicle] = report
            elif owned is not None and owned[1] == "tx":
                tx = parse_tx(message, owned[0])
                self.books.sent[(tx.sender, tx.seq)] = tx
        except ValueError as exc:
            self.books.malformed += 1
            if owned is not None and owned[1] == "tx":
                self.books.bad_tx[owned[0]] += 1  # the step that announced it must not wait for it
            log.warning("comms: dropped a malformed message on %s: %s", key, exc)

    def advance(self) -> bool:
        """Handle every tick that can be handled; True once the final one is done."""
        while self.next_k in self.books.ticks and self._ready(self.next_k):
            tick = self.books.ticks.pop(self.next_k)
            self._handle(tick)
            self.next_k += 1
            if tick.final:
                return True
        return False

    def _expected(self, tick: Tick) -> list[int]:
        """Vehicles whose state of the previous step counts: alive then and still alive now."""
        before = self.previous.alive if self.previous and self.previous.alive is not None else self.vehicles
        now = tick.alive if tick.alive is not None else self.vehicles
        return [v for v in before if v in now]

    def _ready(self, k: int) -> bool:
        if k == self.first:
            return True
        states = self.books.states.get(k - 1, {})
        expected = self._expected(self.books.ticks[k])
        if any(v not in states for v in expected):
            return False
        return all(
            states[v].tx_seq == 0 or (v, states[v].tx_seq) in self.books.sent or self.books.bad_tx[v] for v in expected
        )

    def _announced(self, states: dict[int, StateReport]) -> list[Transmission]:
        """The step's transmissions; one that arrived malformed is written off instead."""
        sent = []
        for v, r in states.items():
            if not r.tx_seq:
                continue
            tx = self.books.sent.pop((v, r.tx_seq), None)
            if tx is not None:
                sent.append(tx)
            else:
                self.books.bad_tx[v] -= 1
        return sent

    def _handle(self, tick: Tick) -> None:
        arrived = self.books.states.pop(tick.k - 1, {})
        states = {v: arrived[v] for v in self._expected(tick) if v in arrived} if tick.k != self.first else {}
        sent = self._announced(states)
        where: dict[int, Kinematics] = {v: r.kinematics for v, r in states.items()}
        events = self.core.submit(sent, where, self.previous.network if self.previous else None)
        self.previous = tick
        alive = tick.alive if tick.alive is not None else self.vehicles
        if tick.final:
            events += self.core.deliver(tick.t, alive)[1] + self.core.finish(tick.t)
            self._publish_events(events)
            self._publish_stats(tick.t, final=True)
            done = {"t": tick.t, "k": tick.k, "events": self.books.published, "malformed": self.books.malformed}
            self.publishers.put(COMMS_DONE_KEY, done)
            return
        batches, delivered = self.core.deliver(tick.t, alive)
        self._publish_events(events + delivered)
        self._publish_stats(tick.t)
        for v in alive:
            self.publishers.put(rx_key(v), rx_message(v, tick.k, tick.t, batches[v]))

    def _publish_stats(self, t: float, final: bool = False) -> None:
        snapshot = self.core.snapshot_due(t, final)
        if snapshot is not None:
            self.publishers.put(COMMS_STATS_KEY, snapshot)

    def _publish_events(self, events: list[LinkEvent]) -> None:
        for event in events:
            self.publishers.put(COMMS_EVENT_KEY, event_message(event))
        self.books.published += len(events)


def run_broker(core: BrokerCore, vehicles: Sequence[int], connect: Sequence[str], start_step: int = 0) -> int:
    """Serve the channel from step start_step until the stop message or the supervisor's disappearance."""

    def handler(publishers: Publishers) -> Handler:
        broker = Broker(core, vehicles, publishers, start_step)

        def handle(key: str, payload: bytes) -> None:
            broker.take(key, payload)
            broker.advance()

        return handle

    keys = (TICK_KEY, f"{ROOT}/vehicle/*/state", f"{ROOT}/vehicle/*/tx")
    return serve("comms", connect, keys, COMMS_ALIVE, handler)

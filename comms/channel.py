"""The acoustic channel as a pure, seeded model: who hears a transmission, when, or why not.

A transmission is offered to every neighbour of its sender in the current graph (one directed link each). On each
link: a `sent` event; then either `dropped` (with its reason) or, at arrival = t + airtime + time of flight + jitter,
`delivered`. Every link has its own random stream derived from (seed, sender, receiver), so results do not depend on
the order in which links are processed. Packets still in flight when the run ends are dropped as `end_of_run`, so
per link: sent = delivered + dropped, always.
"""

from __future__ import annotations

import heapq
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from comms.acoustics import airtime, time_of_flight
from vehicles.geometry import FloatArray
from vehicles.transmission import Transmission

EventKind = Literal["sent", "delivered", "dropped"]
ARRIVAL_SLACK = 1e-9  # s: an arrival this close after a sync instant counts as at it (float rounding of k * dt)


@dataclass(frozen=True, slots=True)
class ChannelParams:
    sound_speed: float = 1500.0  # m/s
    bitrate: float | None = None  # bit/s; None: no airtime
    packet_bytes: int | None = None  # None: the encoded size of each message
    jitter: float = 0.0  # s, uniform on [0, jitter]
    loss: float = 0.0  # Bernoulli loss probability per directed link


@dataclass(frozen=True, slots=True)
class Kinematics:
    """What the channel knows of a receiver at transmission time: inertial position and velocity."""

    position: FloatArray
    velocity: FloatArray


@dataclass(frozen=True, slots=True)
class Reception:
    receiver: int
    sender: int
    seq: int
    stamp: float  # transmission time = time of the data
    arrival: float
    gamma: float
    gamma_dot: float


@dataclass(frozen=True, slots=True)
class LinkEvent:
    t: float
    sender: int
    receiver: int
    seq: int
    kind: EventKind
    delay: float | None = None  # delivered: arrival - transmission time
    reason: str | None = None  # dropped: why


@dataclass
class Channel:
    params: ChannelParams
    seed: int
    _streams: dict[tuple[int, int], np.random.Generator] = field(default_factory=dict)
    _in_flight: list[tuple[float, int, int, int, Reception]] = field(default_factory=list)

    def _stream(self, sender: int, receiver: int) -> np.random.Generator:
        key = (sender, receiver)
        if key not in self._streams:
            self._streams[key] = np.random.default_rng([self.seed, sender, receiver])
        return self._streams[key]

    def transmit(self, tx: Transmission, size_bytes: int, receivers: Mapping[int, Kinematics]) -> list[LinkEvent]:
        """Offer a transmission to each receiver; returns the sent (and immediate dropped) events."""
        events: list[LinkEvent] = []
        size = self.params.packet_bytes or size_bytes
        on_air = airtime(size, self.params.bitrate)
        for receiver in sorted(receivers):
            draws = self._stream(tx.sender, receiver).random(2)  # always two draws: streams stay aligned
            events.append(LinkEvent(tx.t, tx.sender, receiver, tx.seq, "sent"))
            if draws[0] < self.params.loss:
                events.append(LinkEvent(tx.t, tx.sender, receiver, tx.seq, "dropped", reason="loss"))
                continue
            rx = receivers[receiver]
            flight = time_of_flight(np.asarray(tx.position), rx.position, rx.velocity, self.params.sound_speed)
            arrival = tx.t + on_air + flight + draws[1] * self.params.jitter
            reception = Reception(receiver, tx.sender, tx.seq, tx.t, arrival, tx.gamma, tx.gamma_dot)
            heapq.heappush(self._in_flight, (arrival, tx.sender, tx.seq, receiver, reception))
        return events

    def deliver(self, t: float) -> tuple[list[Reception], list[LinkEvent]]:
        """Everything arriving no later than t, in arrival order, with its delivered events."""
        out: list[Reception] = []
        while self._in_flight and self._in_flight[0][0] <= t + ARRIVAL_SLACK:
            out.append(heapq.heappop(self._in_flight)[-1])
        events = [
            LinkEvent(r.arrival, r.sender, r.receiver, r.seq, "delivered", delay=r.arrival - r.stamp) for r in out
        ]
        return out, events

    def flush(self, t: float) -> list[LinkEvent]:
        """Drop whatever is still in flight at the end of the run."""
        left = sorted(self._in_flight)
        self._in_flight.clear()
        return [LinkEvent(t, r.sender, r.receiver, r.seq, "dropped", reason="end_of_run") for *_, r in left]

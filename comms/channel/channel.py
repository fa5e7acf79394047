"""The acoustic channel as a pure, seeded model: who hears a transmission, when, or why not.

A transmission is offered to every neighbour of its sender in the current graph (one directed link each). On each
link: a `sent` event at transmission, then exactly one of
- `dropped` at transmission: a fault (`blackout`, `link_down`, `modem_silent`, set by the broker), the loss
  models (`loss`, `burst`, `range`), or a degraded link's extra loss (`degraded`);
- `dropped` at arrival: `half_duplex` (the receiver's modem was transmitting during the packet) or `collision`
  (another packet overlapped it at the receiver: every other vehicle's transmissions count, neighbour or not; with
  SINR capture only if its SINR, the overlapping packets counted as noise, falls below the capture threshold);
- `delivered` at arrival = t + time of flight + jitter + extra link delay + airtime (the end of the packet);
- `dropped` as `end_of_run` when the run ends first.
So per link: sent = delivered + dropped, always. Every directed link draws from its own random stream derived from
(seed, sender, receiver), a fixed number of draws per packet, so results never depend on processing order.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import msgspec
import numpy as np

from comms.channel.acoustics import flight_time, floats
from comms.channel.link_budget import LinkBudgetRange
from comms.channel.loss import LinkLoss, LossModel
from comms.channel.modem import ModemParams
from comms.records.network import Impairment, Network
from comms.records.records import Kinematics, LinkEvent, Reception, Transmission
from numerics import exp10, log10

ARRIVAL_SLACK = 1e-9  # s: an arrival this close after a sync instant counts as at it (float rounding of k * dt)


def intake_step(arrival: float, dt: float) -> int:
    """The sync step whose instant first takes in a packet arriving then (deliver(t) hands out arrivals <= t)."""
    return math.ceil((arrival - ARRIVAL_SLACK) / dt)


INTACT = Network.of(())  # no link faults
DRAWS_AHEAD = 64  # uniforms a link without loss models draws at once (even: two per packet)
MEMORY = 120.0  # s of past airtime kept for half-duplex and collision checks (far above any packet's duration)


@dataclass(frozen=True, slots=True)
class LinkParams:
    """Per directed link: its loss models (replacing the fleet-wide ones when given: any model, an empty Composite
    for none, whatever its truth value; None takes the fleet's) and extra delay."""

    loss: LossModel | None = None
    extra_delay: float = 0.0  # s


@dataclass(frozen=True, slots=True)
class ChannelParams:
    sound_speed: float = 1500.0  # m/s
    modem: ModemParams = field(default_factory=ModemParams)
    packet_bytes: int | None = None  # None: the encoded size of each message
    jitter: float = 0.0  # s, uniform on [0, jitter]
    loss: LossModel | None = None  # every directed link, unless it has its own
    links: Mapping[tuple[int, int], LinkParams] = field(default_factory=dict)
    capture: Capture | None = None  # None: any overlap at a receiver loses both packets (with collisions on)


@dataclass(frozen=True, slots=True)
class Capture:
    """SINR reception: a packet overlapped by others at its receiver survives when its received level over the noise
    plus every overlapping packet's level (interference counted as noise, powers summed) is at least threshold_db.
    Levels are the link budget's mean received levels (SL - TL + DI at each packet's distance), without shadowing
    or fading; "any overlap loses both" is the pessimistic bound this relaxes."""

    budget: LinkBudgetRange
    threshold_db: float
    noise_power: float = field(init=False, repr=False, compare=False)  # the budget's in-band noise, linear

    def __post_init__(self) -> None:
        # The same at every overlap: worked out once, not at each packet's reception.
        object.__setattr__(self, "noise_power", exp10(self.budget.noise_level_db() / 10.0))

    def survives(self, level_db: float, interferers_db: list[float]) -> bool:
        total = 10.0 * log10(sum((exp10(x / 10.0) for x in interferers_db), self.noise_power))
        return level_db - total >= self.threshold_db


class _Airtime(msgspec.Struct, frozen=True):
    """A packet's presence at one place: [start, end) in s, and whose it is."""

    start: float
    end: float
    sender: int
    seq: int
    level_db: float = 0.0  # received level there, dB re 1 uPa (only with SINR capture)


@dataclass(slots=True)
class _Link:
    rng: np.random.Generator
    loss: LinkLoss | None
    extra_delay: float
    ahead: list[float] = field(default_factory=list)  # without loss models: rng's next draws, the next one last

    def draw(self, distance: float, size: int, t: float) -> tuple[float, str | None, float]:
        """One packet's draws in their order: the jitter's uniform, the loss models' verdict, the fault loss's
        uniform. Without loss models the two uniforms are rng's next two, taken from a block drawn ahead (one numpy
        call per DRAWS_AHEAD / 2 packets, not two per packet): the same numbers in the same order."""
        if self.loss is not None:
            rng = self.rng
            return rng.random(), self.loss.decide(rng, distance, size, t), rng.random()
        ahead = self.ahead
        if not ahead:
            ahead += reversed(self.rng.random(DRAWS_AHEAD).tolist())
        return ahead.pop(), None, ahead.pop()


@dataclass
class Channel:
    params: ChannelParams
    seed: int
    _links: dict[tuple[int, int], _Link] = field(default_factory=dict)
    _in_flight: list[tuple[float, int, int, int, _Airtime, Reception, float]] = field(default_factory=list)
    _heard: dict[int, list[_Airtime]] = field(default_factory=dict)  # every packet in the water at each vehicle
    _sending: dict[int, list[_Airtime]] = field(default_factory=dict)  # each vehicle's own transmissions

    def _link(self, sender: int, receiver: int) -> _Link:
        key = (sender, receiver)
        if key not in self._links:
            own = self._link_params(sender, receiver)
            model = self.params.loss if own.loss is None else own.loss
            rng = np.random.default_rng([self.seed, sender, receiver])
            self._links[key] = _Link(rng, None if model is None else model.link(), own.extra_delay)
        return self._links[key]

    def transmit(
        self,
        tx: Transmission,
        size_bytes: int,
        receivers: set[int],
        everyone: Mapping[int, Kinematics],
        network: Network | None = None,
    ) -> list[LinkEvent]:
        """Put a transmission in the water. receivers: the sender's neighbours now; everyone: all vehicles'
        kinematics at the transmission time (non-neighbours matter for collisions); network: link faults in force.
        Returns the events of now."""
        params, sender = self.params, tx.sender
        intact = network or INTACT
        size = params.packet_bytes or size_bytes
        on_air = params.modem.airtime(size)
        if params.modem.half_duplex:
            self._sending.setdefault(sender, []).append(_Airtime(tx.t, tx.t + on_air, sender, tx.seq))
        events: list[LinkEvent] = []
        sender_at = floats(tx.position)  # once per packet, not once per receiver
        collisions, capture, c = params.modem.collisions, params.capture, params.sound_speed
        # Without collisions a non-neighbour's position does not matter: only the receivers, in the same order (a
        # fleet of 1000 sorted all its ids per packet).
        for j in sorted(everyone if collisions else everyone.keys() & receivers):
            if j == sender:
                continue
            at = everyone[j]
            flight = flight_time(sender_at, floats(at.position), floats(at.velocity), c)
            start = tx.t + flight
            level = capture.budget.received_level_db(flight * c) if capture else 0.0
            if j in receivers:
                impaired = intact.impairment(sender, j)
                start = self._offer(tx, j, start, (flight, level), size, on_air, impaired, events)
            if collisions:  # who heard what only matters to collisions
                self._heard.setdefault(j, []).append(_Airtime(start, start + on_air, sender, tx.seq, level))
        return events

    def _offer(
        self,
        tx: Transmission,
        j: int,
        start: float,
        flight_level: tuple[float, float],
        size: int,
        on_air: float,
        impaired: Impairment,
        events: list[LinkEvent],
    ) -> float:
        """One directed link: draws (jitter, loss models, fault loss), the sent event, the packet's fate so far;
        returns when the packet starts arriving (a lost packet still fills the water and can spoil others).
        flight_level: the time of flight (s) and the received level (dB, for SINR capture)."""
        sender, seq, t = tx.sender, tx.seq, tx.t
        link = self._links.get((sender, j)) or self._link(sender, j)
        flight, level = flight_level
        jitter, reason, degrading = link.draw(flight * self.params.sound_speed, size, t)  # drawn always: streams
        start += jitter * self.params.jitter + link.extra_delay + impaired.extra_delay  # stay aligned
        reason = impaired.lost or reason or ("degraded" if degrading < impaired.extra_loss else None)
        events.append(LinkEvent(t, sender, j, seq, "sent"))
        if reason is not None:
            events.append(LinkEvent(t, sender, j, seq, "dropped", reason=reason))
            return start
        arrival = start + on_air
        there = _Airtime(start, arrival, sender, seq, level)
        reception = Reception(j, sender, seq, tx.data_time, arrival, tx.gamma, tx.gamma_dot)
        heapq.heappush(self._in_flight, (arrival, sender, seq, j, there, reception, t))
        return start

    def deliver(self, t: float) -> tuple[list[Reception], list[LinkEvent]]:
        """Everything whose arrival is no later than t, in arrival order: receptions and their events."""
        out: list[Reception] = []
        events: list[LinkEvent] = []
        in_flight, due = self._in_flight, t + ARRIVAL_SLACK
        modem = self.params.modem
        spoilable = modem.half_duplex or modem.collisions  # else nothing is ever recorded that could spoil a packet
        while in_flight and in_flight[0][0] <= due:
            arrival, sender, seq, j, there, reception, sent_at = heapq.heappop(in_flight)
            reason = self._spoiled(j, there) if spoilable else None
            if reason is None:
                out.append(reception)
                events.append(LinkEvent(arrival, sender, j, seq, "delivered", delay=arrival - sent_at))
            else:
                events.append(LinkEvent(arrival, sender, j, seq, "dropped", reason=reason))
        if spoilable:
            self._forget(t - MEMORY)
        return out, events

    def ahead(self, times: Sequence[float]) -> list[list[Reception]]:
        """What deliver(t) would hand out at each of times in turn (ascending), if nothing were transmitted
        meanwhile (channel lookahead: comms.broker.lookahead): deliver itself, on a copy of what it changes (the
        packets in flight, the airtimes it forgets); it draws nothing at random, so this is its answer."""
        copy = replace(self, _in_flight=list(self._in_flight), _heard=dict(self._heard), _sending=dict(self._sending))
        return [copy.deliver(t)[0] for t in times]

    def first_spoilable(self, t: float) -> float | None:
        """The earliest arrival after t (an intake after t's) of a packet in flight that a transmission made at t or
        later could still spoil (half duplex at its receiver, a collision there); None if none could (neither is
        modelled, or nothing is in flight)."""
        modem = self.params.modem
        if not (modem.half_duplex or modem.collisions):
            return None
        later = [item[0] for item in self._in_flight if item[0] > t + ARRIVAL_SLACK]
        return min(later, default=None)

    def least_delay(self, size_bytes: int, links: Iterable[tuple[int, int]] = ()) -> float:
        """A lower bound on the delay, transmission to arrival, of any packet on links (directed, sender to
        receiver): its airtime plus the least of the links' own extra delays (the time of flight and jitter can be
        zero; a link fault's extra delay only adds). With no links named, the airtime."""
        extra = min((self._link_params(i, j).extra_delay for i, j in links), default=0.0)
        return self.params.modem.airtime(self.params.packet_bytes or size_bytes) + extra

    def _link_params(self, sender: int, receiver: int) -> LinkParams:
        return self.params.links.get((sender, receiver), LinkParams())

    def _spoiled(self, j: int, there: _Airtime) -> str | None:
        """Why a packet could not be received at j, if it could not."""
        if any(_overlap(own, there) for own in self._sending.get(j, [])):
            return "half_duplex"
        overlapping = [o for o in self._heard.get(j, []) if _overlap(o, there) and not _same(o, there)]
        if not overlapping:
            return None
        capture = self.params.capture
        if capture is not None and capture.survives(there.level_db, [o.level_db for o in overlapping]):
            return None
        return "collision"

    def _forget(self, before: float) -> None:
        for table in (self._heard, self._sending):
            for key, items in table.items():
                if items and items[0].end < before:
                    table[key] = [a for a in items if a.end >= before]

    def flush(self, t: float, reason: str = "end_of_run") -> list[LinkEvent]:
        """Drop whatever is still in flight: at the end of the run, or when the broker dies."""
        left = sorted(self._in_flight, key=lambda item: item[:4])
        self._in_flight.clear()
        return [LinkEvent(t, sender, j, seq, "dropped", reason=reason) for _, sender, seq, j, *_ in left]


def _overlap(a: _Airtime, b: _Airtime) -> bool:
    return a.start < b.end and b.start < a.end


def _same(a: _Airtime, b: _Airtime) -> bool:
    return a.sender == b.sender and a.seq == b.seq

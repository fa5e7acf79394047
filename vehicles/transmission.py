"""When a vehicle transmits its coordination state: the policy says when it wants to, the MAC when it may.

Policies (pure decisions on the time, the vehicle's own state and what it last sent):
- periodic: every `period` s (every sync step when period is None);
- event-triggered (logic-based communication, Aguiar & Pascoal 2007; shared/reference/coordination.md): the vehicle
  runs for itself the predictor its neighbours run for it, seeded with what it last sent, and transmits when its
  gamma leaves that prediction by more than h(t) = c0 + c1 exp(-alpha t); never sooner than `min_interval` after
  the last transmission, and at least every `heartbeat` s if one is set.
MAC: free (any time) or TDMA (only at the start of the vehicle's own slot; a wish outside it waits for the slot).

A policy is any object with the `TransmissionPolicy` interface; the built-ins are registered under the entry-point
group `cpf.transmission` like any extension (docs/extending.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar, Protocol, runtime_checkable

from numerics import exp
from vehicles.estimates import FirstOrder, NeighbourEstimate, Predictor


@runtime_checkable
class TransmissionPolicy(Protocol):
    """When a vehicle wants to transmit its (gamma, gamma_dot).

    due(t, dt, now, last): whether it wants to at sync instant t [s] (dt: the step, s), now being what it would send
    (its own gamma, gamma_dot, stamped t) and last what it sent last (None: nothing yet). Pure: the same answer for
    the same arguments. Optional: earliest(lo, dt, last) -> the first step index >= lo at which due() can be true,
    a lower bound that lets lockstep runs skip the bus until then (time windows); without it, every step is asked."""

    def due(self, t: float, dt: float, now: NeighbourEstimate, last: NeighbourEstimate | None) -> bool: ...


@dataclass(frozen=True, slots=True)
class PeriodicPolicy:
    period: float | None = None  # s; None: every sync step

    def due(self, t: float, dt: float, now: NeighbourEstimate, last: NeighbourEstimate | None) -> bool:
        """Whether to transmit at t; half a step of slack keeps the schedule on the step grid."""
        if last is None or self.period is None:
            return True
        return t - last.stamp >= self.period - dt / 2

    def earliest(self, lo: int, dt: float, last: float) -> int:
        return periodic_earliest(self.period, lo, dt, last)


@dataclass(frozen=True, slots=True)
class EventTriggeredPolicy:
    __pydantic_config__: ClassVar[dict[str, bool]] = {"arbitrary_types_allowed": True}  # predictor: the fleet's
    threshold: float  # c0, in units of gamma
    threshold_decay: float = 0.0  # c1
    decay_rate: float = 0.0  # alpha, 1/s
    min_interval: float = 0.0  # s
    heartbeat: float | None = None  # s
    predictor: Predictor = field(default_factory=FirstOrder)  # what the neighbours predict of it: the fleet's
    v_r: float = 1.0

    def h(self, t: float) -> float:
        return self.threshold + self.threshold_decay * exp(-self.decay_rate * t)

    def due(self, t: float, dt: float, now: NeighbourEstimate, last: NeighbourEstimate | None) -> bool:
        if last is None:
            return True
        since = t - last.stamp
        if since < self.min_interval - dt / 2:
            return False
        if self.heartbeat is not None and since >= self.heartbeat - dt / 2:
            return True
        predicted, _ = self.predictor.predict(last, t, self.v_r)
        return abs(now.gamma - predicted) > self.h(t)

    def earliest(self, lo: int, dt: float, last: float) -> int:
        return interval_earliest(self.min_interval, lo, dt, last)


Policy = TransmissionPolicy


@dataclass(frozen=True, slots=True)
class Tdma:
    """Slots of `slot` s in the order of `order`; a frame is len(order) slots. Slot starts lie on the step grid."""

    slot: float
    order: tuple[int, ...]

    @property
    def frame(self) -> float:
        """s from one of a vehicle's slots to its next."""
        return self.slot * len(self.order)

    def may_transmit(self, vehicle_id: int, t: float, dt: float) -> bool:
        frame = self.frame
        start = self.order.index(vehicle_id) * self.slot
        into_slot = (t - start) % frame
        return into_slot < dt / 2 or frame - into_slot < dt / 2

    def first_slot(self, vehicle_id: int, lo: int, dt: float) -> int:
        """The first step >= lo at which may_transmit holds: the steps around the first slot start not before
        step lo's time (a step's window is half a step either side), checked; a full frame's scan if none holds."""
        frame = self.frame
        start = self.order.index(vehicle_id) * self.slot
        slot_start = start + frame * math.ceil((lo * dt - dt / 2 - start) / frame)
        near = round(slot_start / dt)
        for j in range(max(lo, near - 1), near + 2):
            if self.may_transmit(vehicle_id, j * dt, dt):
                while j > lo and self.may_transmit(vehicle_id, (j - 1) * dt, dt):
                    j -= 1
                return j
        for j in range(lo, lo + math.ceil(frame / dt) + 2):  # rounding at a window's edge: look at every step
            if self.may_transmit(vehicle_id, j * dt, dt):
                return j
        raise ValueError(f"vehicle {vehicle_id}: no TDMA slot on the step grid (slot {self.slot:g} s, step {dt:g} s)")


# --- the earliest next transmission (time windows) --------------------------------------------------------------


def earliest_transmission(
    policy: Policy, tdma: Tdma | None, vehicle_id: int, k: int, dt: float, last: float | None, pending: bool
) -> int:
    """The first step after k at which the vehicle may transmit, after its step k: last is the stamp of what it last
    sent (None: nothing yet), pending whether a wish waits for its TDMA slot. No step before the one returned can
    be due by the policy and allowed by the MAC (the supervisor lets the fleet run without the bus until then), so
    every bound below mirrors the float arithmetic of due() and may_transmit() step by step (t = j dt)."""
    first = k + 1 if pending or last is None else _policy_earliest(policy, k + 1, dt, last)
    return first if tdma is None else tdma.first_slot(vehicle_id, first, dt)


def _policy_earliest(policy: Policy, lo: int, dt: float, last: float) -> int:
    """The first step >= lo at which the policy can be due (a lower bound): its own `earliest`, or lo if it has none
    (a policy of someone else's that does not say: asked at every step)."""
    earliest = getattr(policy, "earliest", None)
    return lo if earliest is None else max(lo, int(earliest(lo, dt, last)))


def periodic_earliest(period: float | None, lo: int, dt: float, last: float) -> int:
    """PeriodicPolicy.earliest: the first j >= lo with j dt - last >= period - dt / 2, as due() computes it."""
    if period is None:
        return lo
    return _first(lambda j: j * dt - last >= period - dt / 2, lo, (last + period) / dt)


def interval_earliest(interval: float, lo: int, dt: float, last: float) -> int:
    """EventTriggeredPolicy.earliest: the first j >= lo that min_interval allows (the heartbeat only forces a
    transmission the interval already allows; the predictor may still say no)."""
    return _first(lambda j: not j * dt - last < interval - dt / 2, lo, (last + interval) / dt)


def _first(holds: Callable[[int], bool], lo: int, guess: float) -> int:
    """The first j >= lo for which holds(j), holds monotone in j (false, then true for good); guess: near it."""
    j = max(lo, math.floor(guess))
    while j > lo and holds(j - 1):
        j -= 1
    while not holds(j):
        j += 1
    return j

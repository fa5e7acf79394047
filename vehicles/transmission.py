"""When a vehicle transmits its coordination state: the policy says when it wants to, the MAC when it may.

Policies (pure decisions on the time, the vehicle's own state and what it last sent):
- periodic: every `period` s (every sync step when period is None);
- event-triggered (logic-based communication, Aguiar & Pascoal 2007; shared/reference/coordination.md): the vehicle
  runs for itself the predictor its neighbours run for it, seeded with what it last sent, and transmits when its
  gamma leaves that prediction by more than h(t) = c0 + c1 exp(-alpha t); never sooner than `min_interval` after
  the last transmission, and at least every `heartbeat` s if one is set.
MAC: free (any time) or TDMA (only at the start of the vehicle's own slot; a wish outside it waits for the slot).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from numerics import exp
from vehicles.estimates import NeighbourEstimate, Predictor, predict


@dataclass(frozen=True, slots=True)
class PeriodicPolicy:
    period: float | None = None  # s; None: every sync step

    def due(self, t: float, dt: float, now: NeighbourEstimate, last: NeighbourEstimate | None) -> bool:
        """Whether to transmit at t; half a step of slack keeps the schedule on the step grid."""
        if last is None or self.period is None:
            return True
        return t - last.stamp >= self.period - dt / 2


@dataclass(frozen=True, slots=True)
class EventTriggeredPolicy:
    threshold: float  # c0, in units of gamma
    threshold_decay: float = 0.0  # c1
    decay_rate: float = 0.0  # alpha, 1/s
    min_interval: float = 0.0  # s
    heartbeat: float | None = None  # s
    predictor: Predictor = "first_order"
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
        predicted, _ = predict(last, t, self.predictor, self.v_r)
        return abs(now.gamma - predicted) > self.h(t)


Policy = PeriodicPolicy | EventTriggeredPolicy


@dataclass(frozen=True, slots=True)
class Tdma:
    """Slots of `slot` s in the order of `order`; a frame is len(order) slots. Slot starts lie on the step grid."""

    slot: float
    order: tuple[int, ...]

    def may_transmit(self, vehicle_id: int, t: float, dt: float) -> bool:
        frame = self.slot * len(self.order)
        start = self.order.index(vehicle_id) * self.slot
        into_slot = (t - start) % frame
        return into_slot < dt / 2 or frame - into_slot < dt / 2

    def first_slot(self, vehicle_id: int, lo: int, dt: float) -> int:
        """The first step >= lo at which may_transmit holds: the steps around the first slot start not before
        step lo's time (a step's window is half a step either side), checked; a full frame's scan if none holds."""
        frame = self.slot * len(self.order)
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
    """The first step >= lo at which the policy can be due (the predictor may still say no: a lower bound)."""
    if isinstance(policy, PeriodicPolicy):
        if policy.period is None:
            return lo
        period = policy.period
        return _first(lambda j: j * dt - last >= period - dt / 2, lo, (last + period) / dt)
    interval = policy.min_interval  # the heartbeat only forces a transmission the interval already allows
    return _first(lambda j: not j * dt - last < interval - dt / 2, lo, (last + interval) / dt)


def _first(holds: Callable[[int], bool], lo: int, guess: float) -> int:
    """The first j >= lo for which holds(j), holds monotone in j (false, then true for good); guess: near it."""
    j = max(lo, math.floor(guess))
    while j > lo and holds(j - 1):
        j -= 1
    while not holds(j):
        j += 1
    return j

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
from dataclasses import dataclass

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
        return self.threshold + self.threshold_decay * math.exp(-self.decay_rate * t)

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

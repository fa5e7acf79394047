"""Someone else's law, predictor or transmission policy, contained: what it raises, a non-finite result, or a call that
overruns its CPU-time budget becomes a FloatingPointError naming it, which every engine treats as that vehicle's
failure (vehicles.step adds the vehicle and the time; the run ends with exit 1 and that one line, or goes on without
the vehicle if scenario.on_vehicle_loss says so). The built-ins run unguarded: they are tested, and the guard's
clock reads would cost them a third of their time.

The call itself (exception and CPU budget: time.thread_time, not wall time) is comms.guard's, which the channel's
loss models share.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from comms.guard import CALL_BUDGET, guarded_call, short
from vehicles.coordination import CoordinationGains
from vehicles.estimates import NeighbourEstimate

R = TypeVar("R")


@dataclass(frozen=True, slots=True)
class Guarded:
    """An extension (inner) behind the guard; label: how the error names it ('law my_pkg:Sliding')."""

    inner: Any
    label: str
    budget: float = CALL_BUDGET

    def correction(
        self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
    ) -> float:
        value = self._call(self.inner.correction, gamma, gamma_dot, neighbours, gains)
        return self._finite(value)

    def predict(self, estimate: NeighbourEstimate, t: float, v_r: float) -> tuple[float, float]:
        value = self._call(self.inner.predict, estimate, t, v_r)
        try:
            gamma, rate = value
        except (TypeError, ValueError):
            raise FloatingPointError(f"{self.label} returned {short(value)}, not (gamma, gamma_dot)") from None
        return self._finite(gamma), self._finite(rate)

    def due(self, t: float, dt: float, now: NeighbourEstimate, last: NeighbourEstimate | None) -> bool:
        return bool(self._call(self.inner.due, t, dt, now, last))

    def earliest(self, lo: int, dt: float, last: float) -> int:
        earliest = getattr(self.inner, "earliest", None)
        return lo if earliest is None else int(self._call(earliest, lo, dt, last))

    def _call(self, method: Callable[..., R], *args: Any) -> R:
        return guarded_call(self.label, self.budget, method, *args)

    def _finite(self, value: Any) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise FloatingPointError(f"{self.label} returned {short(value)}, not a finite number")
        return float(value)

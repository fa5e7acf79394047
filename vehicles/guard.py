"""Someone else's law, predictor, transmission policy, path-following controller or vehicle model, contained: what
it raises, a non-finite result, or a call that overruns its CPU-time budget becomes a FloatingPointError naming it,
which every engine treats as that vehicle's failure (vehicles.step adds the vehicle and the time; the run ends with
exit 1 and that one line, or goes on without the vehicle if scenario.on_vehicle_loss says so). The built-ins run
unguarded: they are tested, and the guard's clock reads would cost them a third of their time.

The call itself (exception and CPU budget: time.thread_time, not wall time) is comms.channel.guard's, which the
channel's loss models share.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from comms.channel.guard import CALL_BUDGET, guarded_call, short
from numerics.lanes import takes_lanes
from vehicles.coordination import CoordinationGains
from vehicles.dynamics import Accelerations, PathVectors
from vehicles.estimates import NeighbourEstimate
from vehicles.params import VehicleParams
from vehicles.path_following import ControlOutput, Current, Stage, is_adaptive
from vehicles.vehicle_model import VehicleModel

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
        value = self._call(self.inner.due, t, dt, now, last)
        if not isinstance(value, bool | np.bool_):  # "yes" was true and None false, silently
            raise FloatingPointError(f"{self.label} due() returned {short(value)}, not True or False")
        return bool(value)

    def earliest(self, lo: int, dt: float, last: float) -> int:
        earliest = getattr(self.inner, "earliest", None)
        if earliest is None:
            return lo
        value = self._call(earliest, lo, dt, last)
        whole = isinstance(value, int | np.integer) or (
            isinstance(value, float | np.floating) and float(value).is_integer()
        )
        if isinstance(value, bool) or not whole:  # NaN, inf, 2.5, "3": not a step (int() of NaN raised unguarded)
            raise FloatingPointError(f"{self.label} earliest() returned {short(value)}, not a step index")
        return int(value)

    def control(
        self, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors, gamma: float,
        gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        """The controller's output checked; its drift is dropped (the plant computes its own: a wrong one must not
        move the vehicle) and a planar vehicle's tau_q set to 0 (it has no pitch)."""
        # s as a tuple: a controller that writes into it must not move the vehicle (in process it did, silently)
        out = self._call(self.inner.control, model, params, tuple(s), path, gamma, gamma_dot, v_d, current)
        return self._checked(out, model)

    def _checked(self, out: Any, model: VehicleModel) -> ControlOutput:
        try:
            tau_u, tau_q, tau_r = out.tau
            gamma_ddot, lyapunov = out.gamma_ddot, out.lyapunov
        except (AttributeError, TypeError, ValueError):
            raise FloatingPointError(f"{self.label} returned {short(out)}, not a ControlOutput") from None
        tau_q = self._finite(tau_q) if model.dimension == 3 else 0.0
        tau = (self._finite(tau_u), tau_q, self._finite(tau_r))
        return ControlOutput(tau, self._finite(gamma_ddot), self._finite(lyapunov), None)

    @property
    def adaptive(self) -> bool:
        """Whether what it guards is a controller with a memory (vehicles.path_following.is_adaptive)."""
        return is_adaptive(self.inner)

    def start(self, model: VehicleModel, params: VehicleParams, s: Sequence[float]) -> object:
        return self._call(self.inner.start, model, params, tuple(s))

    def control_with(
        self, memory: object, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors,
        gamma: float, gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        """As control, with an adaptive controller's memory."""
        out = self._call(self.inner.control_with, memory, model, params, tuple(s), path, gamma, gamma_dot, v_d, current)
        return self._checked(out, model)

    def update(
        self, memory: object, model: VehicleModel, params: VehicleParams, stages: Sequence[Stage],
        after: Sequence[float], dt: float,
    ) -> object:  # fmt: skip
        return self._call(self.inner.update, memory, model, params, stages, tuple(after), dt)

    @property
    def lanes(self) -> bool:
        """Whether what it guards takes arrays of lanes (vehicles.lanes): its own word for it."""
        return takes_lanes(self.inner)

    @property
    def dimension(self) -> int:
        """A vehicle model's (the scenario's, given to it when built)."""
        return int(self.inner.dimension)

    def parameters(self) -> VehicleParams:
        value = self._call(self.inner.parameters)
        if not isinstance(value, VehicleParams):
            raise FloatingPointError(f"{self.label} returned {short(value)}, not a VehicleParams")
        return value

    def drift(self, s: Sequence[float], params: VehicleParams) -> Accelerations:
        value = self._call(self.inner.drift, tuple(s), params)
        try:
            (du, dv, dw), (dp, dq, dr) = value
        except (TypeError, ValueError):
            raise FloatingPointError(f"{self.label} returned {short(value)}, not (v_dot, omega_dot)") from None
        linear = (self._finite(du), self._finite(dv), self._finite(dw))
        return linear, (self._finite(dp), self._finite(dq), self._finite(dr))

    def _call(self, method: Callable[..., R], *args: Any) -> R:
        return guarded_call(self.label, self.budget, method, *args)

    def _finite(self, value: Any) -> float:
        if isinstance(value, np.ndarray) and self.lanes:  # one value per lane: every one finite
            if value.dtype != np.float64 or value.ndim != 1 or not np.isfinite(value).all():
                raise FloatingPointError(f"{self.label} returned {short(value)}, not finite numbers")
            return value  # type: ignore[return-value]  # lanes: floats to the code that takes them
        if type(value) is float and math.isfinite(value):  # the usual answer, every stage: checked cheaply first
            return value
        # a real number of any kind (numpy's int64 and float32 too: they were refused), not a bool, finite
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real) or not math.isfinite(value):
            raise FloatingPointError(f"{self.label} returned {short(value)}, not a finite number")
        return float(value)

"""Path-following controllers for tests/test_controller_extension.py: one that works, and one of each way a controller
can break."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Annotated, ClassVar

from annotated_types import Gt

from vehicles.dynamics import PathVectors
from vehicles.params import VehicleParams
from vehicles.path_following import Backstepping, ControlOutput, Current
from vehicles.vehicle_model import VehicleModel


@dataclass(frozen=True)
class Retuned:
    """The backstepping design with its own gains and a tube of 0.5 m: a user's controller built from cpf's parts."""

    k1: Annotated[float, Gt(0)] = 0.8
    k2: Annotated[float, Gt(0)] = 1.5

    def control(
        self, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors, gamma: float,
        gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        inner = Backstepping(delta=-0.5, k1=self.k1, k2=self.k2, k_zeta=1.0)
        return inner.control(model, params, s, path, gamma, gamma_dot, v_d, current)


@dataclass(frozen=True)
class RetunedLanes(Retuned):
    """Retuned, saying it takes arrays of lanes (vehicles.lanes): its arithmetic is Backstepping's, which does."""

    lanes: ClassVar[bool] = True


@dataclass(frozen=True)
class Hidden:
    """Backstepping with a gain its class keeps out of its repr and ==, saying it takes lanes: vehicles.lanes must
    not step two of them with different gains as one."""

    k1: float = field(default=0.5, repr=False, compare=False)
    lanes: ClassVar[bool] = True

    def control(
        self, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors, gamma: float,
        gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        return Backstepping(k1=self.k1).control(model, params, s, path, gamma, gamma_dot, v_d, current)


@dataclass(frozen=True)
class FinAware(Retuned):
    """Retuned, with a field the fleet fills with the fins' moment limit when the scenario has fins (issue 24)."""

    fin_moment: float | None = None


@dataclass(frozen=True)
class NoControl:
    """Has no control method: not a controller."""

    def steer(self) -> float:
        return 0.0


@dataclass(frozen=True)
class WrongSignature:
    """Its control takes the state alone."""

    def control(self, s: Sequence[float]) -> ControlOutput:
        return ControlOutput((0.0, 0.0, 0.0), 0.0, 0.0, None)


@dataclass(frozen=True)
class Raises:
    """Fails once the run is under way: gamma_dot (0 at the start) past `after`."""

    after: float = 0.3

    def control(self, model, params, s, path, gamma, gamma_dot, v_d, current) -> ControlOutput:
        if gamma_dot > self.after:
            raise RuntimeError("lost the path")
        return ControlOutput((0.0, 0.0, 0.0), 0.0, 0.0, None)


@dataclass(frozen=True)
class NotFinite:
    """A surge force of nan once gamma_dot (0 at the start) passes 0.3."""

    def control(self, model, params, s, path, gamma, gamma_dot, v_d, current) -> ControlOutput:
        return ControlOutput((float("nan") if gamma_dot > 0.3 else 0.0, 0.0, 0.0), 0.0, 0.0, None)


@dataclass(frozen=True)
class Slow:
    """Burns 0.3 s of CPU in one call once gamma_dot (0 at the start) passes 0.3."""

    def control(self, model, params, s, path, gamma, gamma_dot, v_d, current) -> ControlOutput:
        if gamma_dot > 0.3:
            end = time.thread_time() + 0.3
            while time.thread_time() < end:
                pass
        return ControlOutput((0.0, 0.0, 0.0), 0.0, 0.0, None)

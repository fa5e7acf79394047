"""The vehicle-model interface: a vehicle's parameters and its dynamics, and the built-in presets as vehicle models.

A vehicle model is any object with the `VehicleModel` interface. The built-ins are the AUV of eqs. (1)-(2)
(vehicles.dynamics) with the numbers of a preset of vehicles.params, one class per preset whose fields are its
parameters (so a scenario's changes to them are its options), registered under the entry-point group `cpf.vehicles`
like any extension (docs/extending.md). A model of another vehicle subclasses `Auv` with other defaults, or writes
its own drift.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Protocol, runtime_checkable

from annotated_types import Gt

from vehicles.dynamics import Accelerations, planar_drift, spatial_drift
from vehicles.params import PRESETS, VehicleParams

Positive = Annotated[float, Gt(0)]
_REMUS = PRESETS["remus100"]


@runtime_checkable
class VehicleModel(Protocol):
    """A vehicle: its parameters and its dynamics.

    - dimension: 3 for the 6-DOF model, 2 for the planar one (x, y, yaw): the scenario's (scenario.dimension), given
      to a field of that name;
    - parameters() -> VehicleParams: its nominal numbers (masses and inertias with added mass [kg, kg m^2], damping
      [N s/m, N s^2/m^2, N m s, N m s^2], weight and buoyancy [N], centre of buoyancy [m], input limits [N, N m]):
      what the controller uses, what the plant's mismatch is drawn around, what bounds its top speed;
    - drift(s, params) -> ((u_dot, v_dot, w_dot) [m/s^2], (p_dot, q_dot, r_dot) [rad/s^2]): its body accelerations
      with no input for the lifted state s (vehicles.dynamics: p [m], R row-major, v [m/s], omega [rad/s]; a planar
      state has z = 0 and no heave, roll or pitch, and its drift none either) and the parameters params (its own, or
      the plant's drawn ones). The inputs enter as in eq. (2): tau_u / M11 on u_dot, tau_q / J22 and tau_r / J33 on
      q_dot and r_dot (vehicles.dynamics.with_inputs), and the state derivative is
      kinematics(s, with_inputs(drift(s, params), tau, params)).
    Must be pure (it runs at every RK4 stage, in every engine) and return finite floats."""

    @property
    def dimension(self) -> int: ...

    def parameters(self) -> VehicleParams: ...

    def drift(self, s: Sequence[float], params: VehicleParams) -> Accelerations: ...


@dataclass(frozen=True)
class Auv:
    """The underactuated AUV of eqs. (1)-(2) with its parameters as fields (units: vehicles.params.VehicleParams;
    3 numbers for the diagonal ones); defaults: the remus100 preset."""

    mass: tuple[Positive, Positive, Positive] = _REMUS.mass
    inertia: tuple[Positive, Positive, Positive] = _REMUS.inertia
    linear_damping: tuple[float, float, float] = _REMUS.linear_damping
    quadratic_damping: tuple[float, float, float] = _REMUS.quadratic_damping
    angular_linear_damping: tuple[float, float, float] = _REMUS.angular_linear_damping
    angular_quadratic_damping: tuple[float, float, float] = _REMUS.angular_quadratic_damping
    weight: float = _REMUS.weight
    buoyancy: float = _REMUS.buoyancy
    center_of_buoyancy: tuple[float, float, float] = _REMUS.center_of_buoyancy
    max_surge_force: float = _REMUS.max_surge_force
    max_torque: float = _REMUS.max_torque
    lift_uv: float = _REMUS.lift_uv
    lift_ur: float = _REMUS.lift_ur
    lift_moment_uv: float = _REMUS.lift_moment_uv
    lift_moment_ur: float = _REMUS.lift_moment_ur
    dimension: int = 3  # the scenario's: 3, or 2 (planar)

    def parameters(self) -> VehicleParams:
        return VehicleParams(
            self.mass, self.inertia, self.linear_damping, self.quadratic_damping, self.angular_linear_damping,
            self.angular_quadratic_damping, self.weight, self.buoyancy, self.center_of_buoyancy,
            self.max_surge_force, self.max_torque, self.lift_uv, self.lift_ur, self.lift_moment_uv,
            self.lift_moment_ur,
        )  # fmt: skip

    @property
    def lanes(self) -> bool:
        """Whether drift takes arrays of lanes (vehicles.lanes): this class's does (it is written in their
        arithmetic); a subclass with a drift of its own says so itself (a class attribute lanes = True)."""
        return type(self).drift is Auv.drift

    def drift(self, s: Sequence[float], params: VehicleParams) -> Accelerations:
        """Eq. (2) with no input (vehicles.dynamics.spatial_drift), or its planar restriction (planar_drift)."""
        return spatial_drift(s, params) if self.dimension == 3 else planar_drift(s, params)


@dataclass(frozen=True)
class Remus100(Auv):
    """The remus100 preset (vehicles.params: REMUS 100, Prestero's drag and lift): entry point `remus100`."""


_NEUTRAL, _LEGACY = PRESETS["remus100_neutral"], PRESETS["remus100_legacy"]


@dataclass(frozen=True)
class Remus100Neutral(Auv):
    """The remus100_neutral preset (REMUS 100 trimmed neutrally buoyant, B = W): entry point `remus100_neutral`."""

    buoyancy: float = _NEUTRAL.buoyancy
    lift_uv: float = _NEUTRAL.lift_uv  # the paper's model: no lift
    lift_ur: float = _NEUTRAL.lift_ur
    lift_moment_uv: float = _NEUTRAL.lift_moment_uv
    lift_moment_ur: float = _NEUTRAL.lift_moment_ur


@dataclass(frozen=True)
class Remus100Legacy(Auv):
    """The remus100_legacy preset (REMUS 100 before its drag was corrected): entry point `remus100_legacy`."""

    quadratic_damping: tuple[float, float, float] = _LEGACY.quadratic_damping
    angular_quadratic_damping: tuple[float, float, float] = _LEGACY.angular_quadratic_damping
    max_surge_force: float = _LEGACY.max_surge_force
    lift_uv: float = _LEGACY.lift_uv
    lift_ur: float = _LEGACY.lift_ur
    lift_moment_uv: float = _LEGACY.lift_moment_uv
    lift_moment_ur: float = _LEGACY.lift_moment_ur

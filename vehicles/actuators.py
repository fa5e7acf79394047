"""Actuators between the controller's inputs and the vehicle: stern planes, rudder and propeller with their limits and
lags, as pure functions of three states integrated with the vehicle's.

The controller asks for (tau_u, tau_q, tau_r). With ideal actuators (None: the paper's model, eq. (2)) the vehicle
gets them, within the preset's constant limits. With these, it gets what the actuators make of them:

- fins (stern planes for pitch, rudder for yaw): a fin at angle d gives the moment L u|u| d, u the surge speed
  through the water (Prestero 2001: M_uu_delta_s = -N_uu_delta_r = 6.15 kg/rad for the REMUS 100, per (m/s)^2 and
  rad), so the commanded angle is tau / (L u|u|), held within +-max_deflection; the fin follows it as a first-order
  servo of time constant fin_time_constant, its rate held within max_rate if one is given;
- propeller: thrust T_max n|n| for the shaft speed n as a fraction of its maximum (thrust of a propeller at a fixed
  advance ratio: proportional to n^2), commanded n = sign(tau_u) sqrt(|tau_u| / T_max) within +-1, followed with
  the time constant thruster_time_constant.

So the torque limit is L u|u| max_deflection (1.5 N m at 1 m/s for the REMUS 100, 9.1 N m at its 2.5 m/s top speed),
not a constant: a vehicle slower than its path needs cannot hold it, as at sea. The states are (d_s, d_r) [rad] and
n [-], starting at 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

import numpy as np
from annotated_types import Gt

from numerics.lanes import copysign, is_lanes, least, sqrt
from vehicles.geometry import Float3
from vehicles.saturation import within

SIZE = 3  # stern-plane angle, rudder angle [rad], shaft speed [fraction of its maximum]
START = (0.0, 0.0, 0.0)
_SLOWEST = 1e-6  # (m/s)^2: below this u|u| a fin's command is its limit's sign (no flow, no moment)


@dataclass(frozen=True, slots=True)
class Actuators:
    """Fins and propeller (module docstring). fin_lift [N m / ((m/s)^2 rad)]; max_deflection [rad];
    fin_time_constant, thruster_time_constant [s]; max_rate [rad/s] (None: the servo's lag alone bounds it);
    max_thrust [N]."""

    fin_lift: Annotated[float, Gt(0)]
    max_deflection: Annotated[float, Gt(0)]
    fin_time_constant: Annotated[float, Gt(0)]
    thruster_time_constant: Annotated[float, Gt(0)]
    max_thrust: Annotated[float, Gt(0)]
    max_rate: Annotated[float, Gt(0)] | None = None
    lanes: ClassVar[bool] = True  # applied and rates take arrays of lanes (vehicles.lanes)

    def applied(self, a: Sequence[float], u: float) -> Float3:
        """(tau_u, tau_q, tau_r) the actuators in state a give at surge speed u [m/s]."""
        flow = self.fin_lift * u * abs(u)
        n = a[2]
        return self.max_thrust * n * abs(n), flow * a[0], flow * a[1]

    def rates(self, a: Sequence[float], commanded: Float3, u: float) -> tuple[float, float, float]:
        """d/dt of the state a for the inputs the controller asks for at surge speed u."""
        flow = u * abs(u)
        lag = 1.0 / self.fin_time_constant
        d_s = lag * (self._deflection(commanded[1], flow) - a[0])
        d_r = lag * (self._deflection(commanded[2], flow) - a[1])
        if self.max_rate is not None:
            d_s, d_r = within(d_s, self.max_rate), within(d_r, self.max_rate)
        wanted = copysign(least(1.0, sqrt(abs(commanded[0]) / self.max_thrust)), commanded[0])
        return d_s, d_r, (wanted - a[2]) / self.thruster_time_constant

    @property
    def fin_moment(self) -> float:
        """The fins' largest moment per (m/s)^2 of surge speed [N m / (m/s)^2]: fin_lift max_deflection."""
        return self.fin_lift * self.max_deflection

    def torque_limit(self, u: float) -> float:
        """The largest pitch or yaw moment the fins give at surge speed u [N m]."""
        return self.fin_moment * u * u

    def _deflection(self, torque: Any, flow: Any) -> Any:
        """The fin angle that gives torque at u|u| = flow, within the limit."""
        limit = self.max_deflection
        if is_lanes(flow) or is_lanes(torque):
            still = abs(flow) < _SLOWEST
            at_rest = np.where(torque == 0.0, 0.0, copysign(limit, torque))
            return np.where(still, at_rest, within(torque / (self.fin_lift * np.where(still, 1.0, flow)), limit))
        if abs(flow) < _SLOWEST:  # no flow: any moment wanted is beyond the fin
            return 0.0 if torque == 0.0 else math.copysign(limit, torque)
        return within(torque / (self.fin_lift * flow), limit)


def remus100(max_thrust: float) -> Actuators:
    """The REMUS 100's: fin lift and deflection limit from Prestero (MIT/WHOI MS thesis, 2001; M_uu_delta_s =
    6.15 kg/rad as transcribed in public code, and +-13.6 deg); the fin servo's and the propeller's time constants
    from Fossen's PythonVehicleSimulator remus100.py (T_delta = 0.1 s, T_n = 1 s; its earlier versions had T_delta =
    1 s, which on the remus100 preset leaves a sway limit cycle of +-0.01 m/s); max_thrust [N]: the vehicle's (the
    preset's max_surge_force holds the published 2.5 m/s top speed). No fin rate is published: none is imposed
    beyond the servo's lag."""
    return Actuators(6.15, math.radians(13.6), 0.1, 1.0, max_thrust)

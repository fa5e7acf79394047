"""A steady level turn: the yaw moment a vehicle must hold to turn at a given rate, which its rudder may not give.

The horizontal counterpart of vehicles.trim. Turning at yaw rate r with speed U through the water, a vehicle
slips: it meets the flow at a drift angle beta (u = U cos beta, v = U sin beta), where the sway equation balances
(v_dot = 0: the centripetal m_u u r against the hull's sway damping and lift). What the drift then leaves in the yaw
row is the moment the rudder must hold, tau_r = -J_r r_dot: the yaw damping, the Munk moment (m_u - m_v) u v and the
lift's moment (Prestero, MIT/WHOI MS thesis, 2001, sec. 3.6-3.7: vehicles.dynamics.lift_terms). It grows with r, so a
vehicle with a bounded yaw moment has a least turning radius U / r_max at each speed: a path that turns tighter is
not flown, whatever the controller (tests/test_turn.py flies the remus100 both sides of the boundary). What the drift
leaves in the surge row is the thrust that keeps U, tau_u = -m_u u_dot: the slip's m_v v r adds to the drag, and a
vehicle short of it slows down in the turn.

Level flight with no roll, pitch, heave or current; the model's own drift gives the forces (its dynamics, any
VehicleModel).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from numerics import cos, sin
from vehicles.params import VehicleParams
from vehicles.trim import bisected
from vehicles.vehicle_model import VehicleModel

_DRIFT = math.radians(45.0)  # the widest drift angle looked at
_SCAN = 45  # intervals of 1 deg each side the root is bracketed over
_HALVINGS = 40
_RATE_HALVINGS = 24  # fastest_turn's: the rate to 6e-8 of the one asked about (each halving is a turn found)


class Turn(NamedTuple):
    """A steady turn: the yaw moment that holds it [N m] (its sign the turn's), the surge speed u [m/s] and the
    surge force that keeps u [N] (the turn's slip adds drag: m_v v r against the surge)."""

    moment: float
    surge: float
    thrust: float


def turn(model: VehicleModel, params: VehicleParams, speed: float, rate: float) -> Turn | None:
    """The steady level turn at `speed` [m/s] through the water and yaw rate `rate` [rad/s] (module docstring); None
    if the sway does not balance within 45 deg of drift."""
    beta = _drift_angle(model, params, speed, rate)
    if beta is None:
        return None
    state = _state(beta, speed, rate)
    (u_dot, _, _), (_, _, r_dot) = model.drift(state, params)
    return Turn(-params.inertia[2] * r_dot, state[12], -params.mass[0] * u_dot)


def fastest_turn(
    model: VehicleModel, params: VehicleParams, speed: float, limits: tuple[float, float], rate: float
) -> float:  # fmt: skip
    """The largest yaw rate [rad/s] up to `rate` whose steady turn at `speed` takes at most limits = (yaw moment
    [N m], thrust [N]), both growing with the rate: bisected; 0 if none."""

    def held(r: float) -> float:  # 1 where the turn at r is within the limits, else -1
        found = turn(model, params, speed, r)
        return 1.0 if found is not None and abs(found.moment) <= limits[0] and found.thrust <= limits[1] else -1.0

    if held(rate) > 0:
        return rate
    return bisected(held, 0.0, rate, 1.0, _RATE_HALVINGS) if held(0.0) > 0 else 0.0


def _drift_angle(model: VehicleModel, params: VehicleParams, speed: float, rate: float) -> float | None:
    def sway(beta: float) -> float:
        return model.drift(_state(beta, speed, rate), params)[0][1]

    step = _DRIFT / _SCAN
    for k in range(_SCAN):  # outward from no drift, a side each: the first root met is the smallest angle
        for lo in (k * step, -(k + 1) * step):
            hi = lo + step
            f_lo, f_hi = sway(lo), sway(hi)
            if f_lo * f_hi <= 0.0:
                return bisected(sway, lo, hi, f_lo, _HALVINGS)
    return None


def _state(beta: float, speed: float, rate: float) -> list[float]:
    """The lifted state (position 0, level, heading along x) moving at speed with drift angle beta, turning at rate."""
    return [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, speed * cos(beta), speed * sin(beta), 0.0,
            0.0, 0.0, rate]  # fmt: skip

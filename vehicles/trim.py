"""Steady flight along a straight line: the pitch moment a vehicle must hold to fly it, which its fins may not give.

A vehicle that is not neutrally buoyant flies a line at an angle of attack: the hull's lift (vehicles.params: the
lift terms) carries its net buoyancy. At that angle the Munk moment (m_w - m_u) u w turns it away from the flow, and
what the lift's own moment and the restoring moment do not hold the fins must. u w is fixed by the net buoyancy, so
that moment grows with the speed more slowly than the fins' moment, which grows with its square (vehicles.actuators):
below some speed no controller can hold the line. On the remus100 preset at 1 m/s it takes 0.94 N m of the fins'
1.46 (1.41 of 3.28 at 1.5 m/s). Vehicle 4 of seed 3 under vehicle.uncertainty.mass = 0.2 (a heave mass 20 % above
the model's and a surge mass 15 % below: a Munk term 59 % larger) takes 2.26 N m at 1 m/s and sinks away from a
level path whatever its controller does (tests/test_trim.py flies it both sides of the boundary).

The trim: pitch theta (nose up), speed U through the water along a line climbing at chi, no roll, yaw or rates. The
body velocity is u = U cos(chi - theta), w = U sin(chi - theta), and theta is the root of the heave equation
w_dot = 0 nearest chi (the smallest angle of attack). The surge force and the pitch moment that hold it are what the
drift leaves in the u and q rows: tau_u = -m_u u_dot, tau_q = -J_q q_dot. A vertical plane only: a turn's sway and
yaw, a current and the fins' own lift force are not in it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

from numerics import cos, sin
from vehicles.params import VehicleParams
from vehicles.vehicle_model import VehicleModel

_ATTACK = math.radians(45.0)  # the widest angle of attack looked at
_SCAN = 45  # intervals of 1 deg each side the root is bracketed over
_HALVINGS = 40  # to 1e-12 of a degree


class Trim(NamedTuple):
    """Steady flight along a line: the pitch moment that holds it [N m] and the surge speed u [m/s] it has then."""

    moment: float
    surge: float


def trim(model: VehicleModel, params: VehicleParams, speed: float, climb: float = 0.0) -> Trim | None:
    """Steady flight at `speed` [m/s] through the water along a line climbing at `climb` [rad] (module docstring);
    None if no trim lies within 45 deg of attack."""
    pitch = _trim_pitch(model, params, speed, climb)
    if pitch is None:
        return None
    state = _state(pitch, speed, climb)
    return Trim(-params.inertia[1] * model.drift(state, params)[1][1], state[12])


def pitch_moment(model: VehicleModel, params: VehicleParams, speed: float, climb: float = 0.0) -> float | None:
    """The pitch moment [N m] of `trim` (None: no trim within 45 deg of attack)."""
    found = trim(model, params, speed, climb)
    return None if found is None else found.moment


def _trim_pitch(model: VehicleModel, params: VehicleParams, speed: float, climb: float) -> float | None:
    def heave(theta: float) -> float:
        return model.drift(_state(theta, speed, climb), params)[0][2]

    step = _ATTACK / _SCAN
    for k in range(_SCAN):  # outward from no angle of attack, a side each: the first root met is the smallest angle
        for lo in (climb + k * step, climb - (k + 1) * step):
            hi = lo + step
            f_lo, f_hi = heave(lo), heave(hi)
            if f_lo * f_hi <= 0.0:
                return bisected(heave, lo, hi, f_lo)
    return None


def bisected(f: Callable[[float], float], a: float, b: float, fa: float, halvings: int = _HALVINGS) -> float:
    """The root of f in [a, b] (f(a) = fa and f(b) of opposite signs or zero), to `halvings` halvings."""
    for _ in range(halvings):
        mid = 0.5 * (a + b)
        fm = f(mid)
        if fa * fm <= 0:
            b = mid
        else:
            a, fa = mid, fm
    return 0.5 * (a + b)


def _state(theta: float, speed: float, climb: float) -> list[float]:
    """The lifted state (position 0) pitched theta nose up, moving at speed along the line climbing at climb."""
    c, s = cos(theta), sin(theta)
    attack = climb - theta
    u, w = speed * cos(attack), speed * sin(attack)
    return [0.0, 0.0, 0.0, c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c, u, 0.0, w, 0.0, 0.0, 0.0]

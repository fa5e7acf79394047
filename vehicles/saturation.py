"""Saturation of the coordination loop: a bounded speed command and a bounded coordination correction.

The path-following controller asks the vehicle to move along its path at gamma_dot |p_d^gamma(gamma)| m/s (its
virtual surge command adds at most k1, as |sigma| < 1). Law (5) alone bounds neither: with long delays or high gains
gamma_dot grows without bound, and so do the speed asked of the vehicle and its path error. Two remedies, each off
unless a scenario asks for it:

- a top speed U: |gamma_dot| <= U / |p_d^gamma(gamma)|, with the path-parameter integrator held at the bound (the
  derivative that would push it further is set to zero: no wind-up, the pattern of the speed_cap fault);
- a bounded correction: v_tilde -> c tanh(v_tilde / c), which is law (5) for small corrections (slope 1 at 0) and
  never exceeds c in size; after the saturated consensus of dsor-isr/farol (cpf_control),
  v_c = -k_c tanh(sum_j a_ij (gamma_i - gamma_j)). c is given, or follows from what the vehicle can do
  (`coordination_acceleration`): the correction accelerates the path's point by v_tilde |p_d^gamma| m/s^2, and a
  vehicle asked for more than its thrust gives falls behind its point and out of its tube (the paper scenario's AUV 1
  released from its speed cap with a large disagreement: path error 1.44 m with a 1.2 m tube, a message every 20 s).

Pure and stateless functions of (gamma, gamma_dot), so a restarted vehicle and both engines saturate identically.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from numerics import tanh
from numerics.lanes import greatest, least, sqrt
from vehicles.dynamics import Model, PathVectors
from vehicles.params import VehicleParams
from vehicles.paths import Path

# The share of a vehicle's acceleration the coordination correction may ask of it: the rest is left to the
# path-following controller, whose feedback must still act for the error to stay in the tube (Lemma 1 assumes it
# can). A design choice, not derived: half leaves each the same authority.
COORDINATION_SHARE = 0.5


def rate_bound(model: Model, path: Path, gamma: float, top_speed: float) -> float:
    """The largest |gamma_dot| that keeps the path's point within top_speed m/s, for the path as the model sees it
    (a planar vehicle: its horizontal projection); inf where the path does not move with gamma."""
    return slope_rate_bound(path_slope(model, path, gamma), top_speed)


def slope_rate_bound(size: float, top_speed: float) -> float:
    """rate_bound where |p_d^gamma| = size (slope_size of the path point as the model sees it); size may be lanes."""
    if isinstance(size, np.ndarray):
        moving = size > 0.0
        return np.where(moving, top_speed / np.where(moving, size, 1.0), math.inf)
    return top_speed / size if size > 0.0 else math.inf


def path_slope(model: Model, path: Path, gamma: float) -> float:
    """|p_d^gamma(gamma)|, m per unit of gamma, of the path as the model sees it (a planar vehicle: its horizontal
    projection)."""
    return slope_size(model.path_seen(path.evaluate_floats(gamma)))


def slope_size(point: PathVectors) -> float:
    """|p_d^gamma| of a path point (p_d, p_d^gamma, p_d^gammagamma), m per unit of gamma."""
    slope = point[1]
    return sqrt(slope[0] * slope[0] + slope[1] * slope[1] + slope[2] * slope[2])


def coordination_acceleration(params: VehicleParams) -> float:
    """m/s^2 of along-path acceleration the coordination may ask: COORDINATION_SHARE of full thrust over the surge
    mass (rigid body + added), the acceleration from rest."""
    return COORDINATION_SHARE * params.max_surge_force / params.mass[0]


def bounded_correction(v_tilde: float, limit: float) -> float:
    """limit tanh(v_tilde / limit): v_tilde for |v_tilde| << limit, never more than limit in size (either may be
    lanes)."""
    ratio = v_tilde / limit
    return limit * tanh(ratio)


def clamp(value: float, low: float, high: float) -> float:
    """value within [low, high] (NaN stays NaN: a broken state is not hidden); any of them may be lanes."""
    if isinstance(value, np.ndarray) or isinstance(low, np.ndarray) or isinstance(high, np.ndarray):
        return np.where(value < low, low, np.where(value > high, high, value))
    return low if value < low else high if value > high else value


def within(x: Any, limit: Any) -> Any:
    """x within [-limit, limit] for limit >= 0, tested as `limit if x > limit else -limit if x < -limit else x`
    (NaN stays NaN); either may be lanes."""
    if isinstance(x, np.ndarray) or isinstance(limit, np.ndarray):
        return np.where(x > limit, limit, np.where(x < -limit, -limit, x))
    return limit if x > limit else -limit if x < -limit else x


def hold(gamma_ddot: float, gamma_dot: float, low: float, high: float) -> float:
    """gamma_ddot with the part that would push gamma_dot past a bound it sits at removed (no wind-up); any of them
    may be lanes."""
    if isinstance(gamma_dot, np.ndarray):
        gamma_ddot = np.where(gamma_dot >= high, least(gamma_ddot, 0.0), gamma_ddot)
        return np.where(gamma_dot <= low, greatest(gamma_ddot, 0.0), gamma_ddot)
    if gamma_dot >= high:
        gamma_ddot = min(gamma_ddot, 0.0)
    if gamma_dot <= low:
        gamma_ddot = max(gamma_ddot, 0.0)
    return gamma_ddot

"""Saturation of the coordination loop: a bounded speed command and a bounded coordination correction.

The path-following controller asks the vehicle to move along its path at gamma_dot |p_d^gamma(gamma)| m/s (its
virtual surge command adds at most k1, as |sigma| < 1). Law (5) alone bounds neither: with long delays or high gains
gamma_dot grows without bound, and so do the speed asked of the vehicle and its path error. Two remedies, each off
unless a scenario asks for it:

- a top speed U: |gamma_dot| <= U / |p_d^gamma(gamma)|, with the path-parameter integrator held at the bound (the
  derivative that would push it further is set to zero: no wind-up, the pattern of the speed_cap fault);
- a bounded correction: v_tilde -> c tanh(v_tilde / c), which is law (5) for small corrections (slope 1 at 0) and
  never exceeds c in size; after the saturated consensus of dsor-isr/farol (cpf_control),
  v_c = -k_c tanh(sum_j a_ij (gamma_i - gamma_j)).

Pure and stateless functions of (gamma, gamma_dot), so a restarted vehicle and both engines saturate identically.
"""

from __future__ import annotations

import math

from numerics import tanh
from vehicles.dynamics import Model
from vehicles.paths import Path


def rate_bound(model: Model, path: Path, gamma: float, top_speed: float) -> float:
    """The largest |gamma_dot| that keeps the path's point within top_speed m/s, for the path as the model sees it
    (a planar vehicle: its horizontal projection); inf where the path does not move with gamma."""
    slope = model.path_seen(path.evaluate_floats(gamma))[1]
    size = math.sqrt(slope[0] * slope[0] + slope[1] * slope[1] + slope[2] * slope[2])
    return top_speed / size if size > 0.0 else math.inf


def bounded_correction(v_tilde: float, limit: float) -> float:
    """limit tanh(v_tilde / limit): v_tilde for |v_tilde| << limit, never more than limit in size."""
    return limit * tanh(v_tilde / limit)


def clamp(value: float, low: float, high: float) -> float:
    """value within [low, high] (NaN stays NaN: a broken state is not hidden)."""
    return low if value < low else high if value > high else value


def hold(gamma_ddot: float, gamma_dot: float, low: float, high: float) -> float:
    """gamma_ddot with the part that would push gamma_dot past a bound it sits at removed (no wind-up)."""
    if gamma_dot >= high:
        gamma_ddot = min(gamma_ddot, 0.0)
    if gamma_dot <= low:
        gamma_ddot = max(gamma_ddot, 0.0)
    return gamma_ddot

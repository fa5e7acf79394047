"""Coordination of the path parameters gamma_i: law (5) of the paper (its graph matrices are in comms.graph).

Law (5), vector form: v_tilde = -K L gamma_dot - K2 (omega + K L gamma), omega = gamma_dot. Taken literally, together
with the speed-error term of the path-following update it settles at gamma_dot = k_zeta v_r / (k_zeta + K2), not at
v_r (shared/reference/coordination.md). The corrected law replaces omega by the speed error omega - v_r 1; the
paper's Lyapunov argument is unchanged because L_K 1 = 0. "corrected" is the default, "literal" stays selectable.

Decentralised form for vehicle i, using only what it holds of its neighbours j in N_i:
    v_tilde_i = -k_i sum_j (gamma_dot_i - gamma_dot_j) - k2_i (s_i + k_i sum_j (gamma_i - gamma_j)),
with s_i = gamma_dot_i - v_r (corrected) or gamma_dot_i (literal).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from comms.records import FloatArray

Law = Literal["corrected", "literal"]


@dataclass(frozen=True, slots=True)
class CoordinationGains:
    """k: K = diag(k_i) (1/s per unit of neighbour disagreement), k2: K2 = diag(k2_i) in 1/s, v_r in 1/s."""

    k: float = 0.2
    k2: float = 1.0
    v_r: float = 1.0
    law: Law = "corrected"


def correction(
    gamma: float, gamma_dot: float, neighbours: Iterable[tuple[float, float]], gains: CoordinationGains
) -> float:
    """v_tilde_i from vehicle i's own (gamma, gamma_dot) and its (estimates of) neighbours' (gamma_j, gamma_dot_j)."""
    sum_gamma = 0.0
    sum_rate = 0.0
    for gamma_j, gamma_dot_j in neighbours:
        sum_gamma += gamma - gamma_j
        sum_rate += gamma_dot - gamma_dot_j
    speed_term = gamma_dot - gains.v_r if gains.law == "corrected" else gamma_dot
    return -gains.k * sum_rate - gains.k2 * (speed_term + gains.k * sum_gamma)


def l_k(k_diag: Sequence[float]) -> FloatArray:
    """L_K = I - 1 1' K^-1 / (1' K^-1 1), the projection whose kernel is span{1} (Ghabcheloo et al., 2006)."""
    k_inv = 1.0 / np.asarray(k_diag, dtype=float)
    ones = np.ones(len(k_inv))
    return np.eye(len(k_inv)) - np.outer(ones, k_inv) / float(k_inv.sum())


def correction_vector(
    gamma: FloatArray, gamma_dot: FloatArray, lap: FloatArray, k_diag: FloatArray, k2_diag: FloatArray,
    v_r: float, law: Law,
) -> FloatArray:  # fmt: skip
    """Law (5) in the paper's vector form, for checking the decentralised one."""
    speed = gamma_dot - v_r if law == "corrected" else gamma_dot
    result: FloatArray = -k_diag * (lap @ gamma_dot) - k2_diag * (speed + k_diag * (lap @ gamma))
    return result

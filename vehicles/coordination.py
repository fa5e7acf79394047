"""Coordination of the path parameters gamma_i: the coordination-law interface and law (5) of the paper (its graph
matrices are in comms.records.graph).

A law is any object with the `CoordinationLaw` interface: from vehicle i's own (gamma, gamma_dot), what it predicts
of its neighbours and the fleet's gains, the correction v_tilde_i that enters gamma_ddot_i (paper, eq. (3)). The
built-ins are registered under the entry-point group `cpf.coordination` like any extension (docs/extending.md).

Law (5), vector form: v_tilde = -K L gamma_dot - K2 (omega + K L gamma), omega = gamma_dot. Taken literally, together
with the speed-error term of the path-following update it settles at gamma_dot = k_zeta v_r / (k_zeta + K2), not at
v_r (shared/reference/coordination.md). The corrected law replaces omega by the speed error omega - v_r 1; the
paper's Lyapunov argument is unchanged because L_K 1 = 0. "corrected" is the default, "literal" stays selectable.

Decentralised form for vehicle i, using only what it holds of its neighbours j in N_i:
    v_tilde_i = -k_i sum_j (gamma_dot_i - gamma_dot_j) - k2_i (s_i + k_i sum_j (gamma_i - gamma_j)),
with s_i = gamma_dot_i - v_r (corrected) or gamma_dot_i (literal).

`saturated`: the law used with logic-based communication in sea trials (Rego, Hung, Jones, Pascoal & Aguiar, IET
2019; dsor-isr/farol cpf_control): a bounded speed correction from the gamma disagreement alone,
    v_c,i = -k_c tanh(sum_j (gamma_i - gamma_j) / width),   v_tilde_i = -k2_i (gamma_dot_i - v_r - v_c,i),
so gamma_dot_i is driven to v_r + v_c,i (|v_c,i| < k_c) and no neighbour's rate enters the law: an old rate cannot
be extrapolated into it, which is what breaks law (5) over long silences (docs/stability.md).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Annotated, Literal, Protocol, runtime_checkable

import numpy as np
from annotated_types import Gt

from comms.records.records import FloatArray
from numerics import tanh

Law = Literal["corrected", "literal"]


@dataclass(frozen=True, slots=True)
class CoordinationGains:
    """k: K = diag(k_i) (1/s per unit of neighbour disagreement), k2: K2 = diag(k2_i) in 1/s, v_r in unit of gamma
    per s: the fleet's gains from [coordination], which any law may use."""

    k: float = 0.2
    k2: float = 1.0
    v_r: float = 1.0


@runtime_checkable
class CoordinationLaw(Protocol):
    """What a coordination law computes, for vehicle i at one RK4 stage.

    correction(gamma, gamma_dot, neighbours, gains): v_tilde_i [unit of gamma per s^2], the term law (5) adds to
    gamma_ddot_i; gamma [unit of gamma] and gamma_dot [unit of gamma per s] are vehicle i's own, neighbours the
    predicted (gamma_j, gamma_dot_j) of each neighbour it holds a fresh estimate of (possibly none), gains the
    fleet's [coordination] gains. Must be pure (it runs four times per step, in every engine and in re-simulation)
    and return a finite float."""

    def correction(
        self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
    ) -> float: ...


def law5(
    gamma: float, gamma_dot: float, neighbours: Iterable[tuple[float, float]], gains: CoordinationGains, literal: bool
) -> float:
    """v_tilde_i of law (5) from vehicle i's own (gamma, gamma_dot) and its neighbours' (gamma_j, gamma_dot_j)."""
    sum_gamma = 0.0
    sum_rate = 0.0
    for gamma_j, gamma_dot_j in neighbours:
        sum_gamma += gamma - gamma_j
        sum_rate += gamma_dot - gamma_dot_j
    speed_term = gamma_dot if literal else gamma_dot - gains.v_r
    return -gains.k * sum_rate - gains.k2 * (speed_term + gains.k * sum_gamma)


@dataclass(frozen=True, slots=True)
class Corrected:
    """Law (5) on the speed error gamma_dot - v_r: settles at v_r (the default)."""

    def correction(
        self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
    ) -> float:
        return law5(gamma, gamma_dot, neighbours, gains, False)


@dataclass(frozen=True, slots=True)
class LiteralLaw:
    """Law (5) as printed: settles at k_zeta v_r / (k_zeta + k2)."""

    def correction(
        self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
    ) -> float:
        return law5(gamma, gamma_dot, neighbours, gains, True)


@dataclass(frozen=True, slots=True)
class Saturated:
    """v_tilde_i = -k2 (gamma_dot_i - v_r - v_c,i), v_c,i = -k_c tanh(sum_j (gamma_i - gamma_j) / width): the
    bounded, rate-free law of the module docstring. k_c [unit of gamma per s]: the largest speed correction; width
    [unit of gamma]: the disagreement over which it saturates (the slope at agreement is k_c / width per s)."""

    k_c: Annotated[float, Gt(0)] = 0.2
    width: Annotated[float, Gt(0)] = 1.0

    def correction(
        self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
    ) -> float:
        disagreement = 0.0
        for gamma_j, _ in neighbours:
            disagreement += gamma - gamma_j
        speed = -self.k_c * tanh(disagreement / self.width)
        return -gains.k2 * (gamma_dot - gains.v_r - speed)


def correction(
    gamma: float, gamma_dot: float, neighbours: Iterable[tuple[float, float]], gains: CoordinationGains,
    law: Law = "corrected",
) -> float:  # fmt: skip
    """v_tilde_i of law (5), corrected or literal (for analysis and tests; runs call their law's object)."""
    return law5(gamma, gamma_dot, neighbours, gains, law == "literal")


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

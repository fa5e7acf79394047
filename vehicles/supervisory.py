"""Adaptive switching supervisory path following, after Aguiar & Hespanha, "Trajectory-tracking and path-following
of underactuated autonomous vehicles with parametric modeling uncertainty" (IEEE TAC 52(8), 2007), Sec. IV: a family
of candidate controllers over a set of parameters, a multi-estimator, monitoring signals and hysteresis switching.

Parameter set. The uncertain parameters are the vehicle's inertia (every M_ii and J_ii, added mass included, scaled
together) and, for each degree of freedom i (u, v, w, p, q, r: the rows of eq. (2)), its linear and its quadratic
damping. Each factor takes `levels` values evenly spread over [1 - spread, 1 + spread] times nominal (0.4, 1 and 1.6
at spread 0.6 with 3 levels). Restoring terms stay nominal. Damping is diagonal, so a row's acceleration depends on
its own damping and on the inertia (through its own and, in the Coriolis and Munk terms, the others'): for a given
inertia level the rows' damping can be estimated each on its own, and the levels^3 models with every row at the same
(inertia, linear, quadratic) levels give every row's prediction for every candidate of the set, exactly.

Candidate controllers: the delta-shifted backstepping law of vehicles.path_following with the candidate's
parameters (certainty equivalence); its V never increases on the plant it is designed for.

Multi-estimator and monitoring signals (Hespanha, Liberzon & Morse, "Hysteresis-based switching algorithms for
supervisory control of uncertain systems", Automatica 39(2), 2003). For candidate p and row i, the estimator
nu_hat_p' = -lambda (nu_hat_p - nu) + a_p(s) + b_p tau has the error e_p = nu_hat_p - nu, which obeys

    e_p' = -lambda e_p + (a_p(s) + b_p tau - nu_dot),      mu_p' = -forgetting mu_p + e_p^2,   mu_p(0) = floor

with a_p the model's drift and b_p tau its inputs' part (vehicles.dynamics.with_inputs) for p's parameters, so e_p
is the low-passed error of p's prediction of the acceleration. It is computed once per step from the RK4 stages
the vehicle steered at: nu_dot as (nu(t + dt) - nu(t)) / dt, which RK4 makes the weighted mean of the stages'
accelerations, and the prediction of the parameters in use averaged the same way, so that it is exact (to rounding)
on a plant with those parameters; the other candidates' differ from it by their accelerations at the step's mean
state (an O(dt^2) approximation of their own average, which only scales their differences). lambda = k2 by default:
a wrong candidate shows within the time the velocity loop it acts on takes to settle.

Switching logic, scale-independent hysteresis: the inertia level moves to the one whose best damping in every row
gives the least cost, J_L = sum_i w_i min_(l,q) mu_(L,l,q),i, when (1 + h) J_min < J_current, and within the inertia
level each row's damping moves to q = argmin mu_q,i when (1 + h) mu_q,i < mu_sigma_i,i. w_i is 1 for the linear rows
and delta^2 for the angular ones (an angular velocity error times |delta| is the speed error it gives the point the
controller steers). With no forgetting (the default) and a finite set, the number of switches is finite for any
h > 0 (the theorem cited); the selections put together are the parameters the controller uses. The floor, 1e-6
(m/s)^2 s by default (1 mm/s of estimation error held for 1 s), is the evidence a first switch needs: without it the
first steps, where every error is near zero, would switch on rounding.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Annotated, Literal

import numpy as np
from annotated_types import Ge, Gt, Lt

from comms.records.records import FloatArray
from numerics import exp
from vehicles.dynamics import PathVectors
from vehicles.geometry import Float3
from vehicles.params import VehicleParams
from vehicles.path_following import (
    STAGE_WEIGHTS,
    Backstepping,
    ControlOutput,
    Current,
    Stage,
    accelerations,
    law,
    stage_mean,
    step_mean,
)
from vehicles.vehicle_model import VehicleModel

ROWS = 6  # u, v, w, p, q, r
# The groups each factor of a candidate scales: (translational rows, rotational rows).
_GROUPS = (
    ("mass", "inertia"),
    ("linear_damping", "angular_linear_damping"),
    ("quadratic_damping", "angular_quadratic_damping"),
)


@dataclass(frozen=True, slots=True, eq=False)
class SupervisorMemory:
    """What the supervisor carries from step to step."""

    candidate: Backstepping  # the candidate controllers' law and gains
    error: FloatArray  # e_p,i, (candidates, 6) [m/s, rad/s]
    monitor: FloatArray  # mu_p,i, (candidates, 6) [(m/s)^2 s, (rad/s)^2 s]
    selected: tuple[int, ...]  # sigma_i: the candidate each row uses (all of one inertia level)
    params: VehicleParams  # the parameters the selections give
    switches: int = 0  # how many times a row has switched


@dataclass(frozen=True, slots=True)
class Supervisory:
    """The supervisor of the module docstring (entry point `supervisory`). The candidate controllers' gains as
    Backstepping's (delta [m], k1 [m/s], k2 and k_zeta [1/s], damping); spread: the parameter set's relative
    half-width; levels: values per parameter (odd: the nominal is one); rate: the estimators' lambda [1/s] (None:
    k2); forgetting: the monitoring signals' [1/s] (0: none); hysteresis: h; floor: mu's initial value."""

    delta: float = -1.0
    k1: Annotated[float, Gt(0)] = 0.5
    k2: Annotated[float, Gt(0)] = 1.0
    k_zeta: Annotated[float, Gt(0)] = 1.0
    damping: Literal["feedforward", "cancel"] = "feedforward"
    spread: Annotated[float, Gt(0), Lt(1)] = 0.6
    levels: Annotated[int, Ge(2)] = 3
    rate: Annotated[float, Gt(0)] | None = None
    forgetting: Annotated[float, Ge(0)] = 0.0
    hysteresis: Annotated[float, Gt(0)] = 0.1
    floor: Annotated[float, Gt(0)] = 1e-6

    def __post_init__(self) -> None:
        if self.delta == 0.0:
            raise ValueError("delta must be non-zero (delta = 0 leaves the pitch and yaw rates unsteerable)")
        if self.levels % 2 == 0:
            raise ValueError(f"levels must be odd so that the nominal parameters are a candidate, got {self.levels}")

    def control(
        self, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors, gamma: float,
        gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        """Without a memory: the nominal candidate (what the supervisor starts with)."""
        return law(self._candidate(), model, params, s, path, gamma_dot, v_d, current)[0]

    def start(self, model: VehicleModel, params: VehicleParams, s: Sequence[float]) -> SupervisorMemory:
        count = len(_candidates(params, self.spread, self.levels))
        nominal = count // 2  # the grid's centre: every factor 1
        error, monitor = np.zeros((count, ROWS)), np.full((count, ROWS), self.floor)
        return SupervisorMemory(self._candidate(), error, monitor, (nominal,) * ROWS, params)

    def control_with(
        self, memory: object, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors,
        gamma: float, gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        assert isinstance(memory, SupervisorMemory)
        out = law(memory.candidate, model, memory.params, s, path, gamma_dot, v_d, current)[0]
        return out if memory.params is params else out._replace(drift=None)  # its drift is the nominal model's only

    def update(
        self, memory: object, model: VehicleModel, params: VehicleParams, stages: Sequence[Stage],
        after: Sequence[float], dt: float,
    ) -> SupervisorMemory:  # fmt: skip
        assert isinstance(memory, SupervisorMemory)
        candidates = _candidates(params, self.spread, self.levels)
        before = stages[0][0]
        residual = _predicted(model, memory.params, candidates, stages, after) - _measured(before, after, dt)
        lam = self.k2 if self.rate is None else self.rate
        decay = exp(-lam * dt)
        error = decay * memory.error + ((1.0 - decay) / lam) * residual
        keep = exp(-self.forgetting * dt)
        monitor = keep * memory.monitor + dt * error * error + (1.0 - keep) * self.floor
        arm = self.delta * self.delta
        weights = (1.0, 1.0, 1.0, arm, arm, arm)
        selected = _switched(monitor, memory.selected, self.hysteresis, self.levels, weights)
        if selected == memory.selected:
            return SupervisorMemory(memory.candidate, error, monitor, selected, memory.params, memory.switches)
        switches = memory.switches + sum(a != b for a, b in zip(selected, memory.selected, strict=True))
        chosen = _assembled(params, candidates, selected)
        return SupervisorMemory(memory.candidate, error, monitor, selected, chosen, switches)

    def _candidate(self) -> Backstepping:
        return Backstepping(self.delta, self.k1, self.k2, self.k_zeta, self.damping)


def factors(spread: float, levels: int) -> tuple[float, ...]:
    """The values each parameter takes, relative to nominal: levels points over [1 - spread, 1 + spread]."""
    return tuple(float(f) for f in np.linspace(1.0 - spread, 1.0 + spread, levels))


@functools.lru_cache(maxsize=64)
def _candidates(params: VehicleParams, spread: float, levels: int) -> tuple[VehicleParams, ...]:
    """The candidate parameter sets, every row at the same levels (inertia, linear, quadratic damping): the grid in
    the order of itertools.product, so the centre one is the nominal."""
    values = factors(spread, levels)
    grid = [(a, b, c) for a in values for b in values for c in values]
    return tuple(_scaled(params, level) for level in grid)


def _scaled(params: VehicleParams, level: tuple[float, float, float]) -> VehicleParams:
    """params with (inertia, linear damping, quadratic damping) scaled by level's factors in every row."""
    changes = {}
    for factor, groups in zip(level, _GROUPS, strict=True):
        for group in groups:
            changes[group] = tuple(factor * x for x in getattr(params, group))
    return replace(params, **changes)  # type: ignore[arg-type]


def _predicted(
    model: VehicleModel, chosen: VehicleParams, candidates: Sequence[VehicleParams], stages: Sequence[Stage],
    after: Sequence[float],
) -> FloatArray:  # fmt: skip
    """Each candidate's mean acceleration over the step (candidates, 6): the parameters in use (chosen) averaged
    over the stages as RK4 averages them, plus each candidate's difference from them at the step's mean state."""
    tau = _mean_inputs(stages)
    exact = stage_mean(model, chosen, stages)
    mid = [0.5 * (a + b) for a, b in zip(stages[0][0], after, strict=True)]
    base = accelerations(model, chosen, mid, tau)
    shift = np.array([e - b for e, b in zip(exact, base, strict=True)])
    return np.array([accelerations(model, p, mid, tau) for p in candidates]) + shift


def _mean_inputs(stages: Sequence[Stage]) -> Float3:
    """The inputs averaged over the step as RK4 averages its stages."""
    u, q, r = (sum(w * tau[i] for w, (_, tau) in zip(STAGE_WEIGHTS, stages, strict=True)) for i in range(3))
    return u, q, r


def _measured(before: Sequence[float], after: Sequence[float], dt: float) -> FloatArray:
    """The accelerations the vehicle saw over the step, (6,)."""
    return np.array(step_mean(before, after, dt))


def _switched(
    monitor: FloatArray, selected: tuple[int, ...], hysteresis: float, levels: int, weights: Sequence[float]
) -> tuple[int, ...]:  # fmt: skip
    """The rows' selections after the hysteresis tests of the module docstring: the inertia level first, then each
    row's damping within it (candidates in the grid's order: inertia level major)."""
    per_level = levels * levels
    slices = monitor.reshape(levels, per_level, ROWS)
    cost = (slices.min(axis=1) * np.asarray(weights)).sum(axis=1).tolist()  # elementwise, not BLAS: any CPU's bits
    current = selected[0] // per_level
    best = min(range(levels), key=cost.__getitem__)  # the first of equals, as numpy's argmin
    if (1.0 + hysteresis) * cost[best] < cost[current]:
        return tuple(best * per_level + int(j) for j in slices[best].argmin(axis=0))
    rows = monitor.tolist()
    out = []
    for i, j in enumerate(slices[current].argmin(axis=0).tolist()):
        candidate = current * per_level + j
        out.append(candidate if (1.0 + hysteresis) * rows[candidate][i] < rows[selected[i]][i] else selected[i])
    return tuple(out)


def _assembled(params: VehicleParams, candidates: Sequence[VehicleParams], selected: Sequence[int]) -> VehicleParams:
    """The parameters the rows' selections give: row i's inertia and damping from its own candidate."""
    changes: dict[str, tuple[float, float, float]] = {}
    for groups in _GROUPS:
        for rows, group in zip(((0, 1, 2), (3, 4, 5)), groups, strict=True):
            values = [getattr(candidates[selected[row]], group)[k] for k, row in enumerate(rows)]
            changes[group] = (values[0], values[1], values[2])
    return replace(params, **changes)  # type: ignore[arg-type]

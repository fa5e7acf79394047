"""One vehicle's whole closed loop as pure functions: dynamics + path following + coordination + estimates.

`step` advances a VehicleState by one fixed step with classical Runge-Kutta 4 and returns the telemetry at the start
of the step. Both engines call exactly this: the in-process engine for every vehicle in a loop, the vehicle process
once per sync step. Neighbour data enter only through `receive`, so what a vehicle knows is explicit.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from vehicles.coordination import CoordinationGains, correction
from vehicles.dynamics import Model
from vehicles.estimates import NeighbourEstimate, Predictor, newer, predict
from vehicles.geometry import FloatArray
from vehicles.params import VehicleParams
from vehicles.path_following import ControllerConstants, PathFollowingGains, PathFollowingOutput, path_following
from vehicles.paths import Path


@dataclass(frozen=True, slots=True)
class VehicleConfig:
    vehicle_id: int
    model: Model
    params: VehicleParams
    path: Path
    path_following: PathFollowingGains
    coordination: CoordinationGains
    predictor: Predictor = "first_order"
    constants: ControllerConstants = field(init=False)

    def __post_init__(self) -> None:
        # Computed once per vehicle: the controller uses them at every RK4 stage.
        object.__setattr__(self, "constants", ControllerConstants.of(self.model, self.params, self.path_following))


@dataclass(frozen=True, slots=True)
class VehicleState:
    t: float
    x: FloatArray  # dynamic state of the model (see vehicles.dynamics)
    gamma: float
    gamma_dot: float
    estimates: Mapping[int, NeighbourEstimate] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Telemetry:
    """Everything a vehicle reports about one instant."""

    vehicle_id: int
    t: float
    gamma: float
    gamma_dot: float
    x: FloatArray
    error: FloatArray  # p - p_d(gamma), m
    tau: FloatArray
    correction: float  # v_tilde_i
    lyapunov: float


@dataclass(frozen=True, slots=True)
class Disturbances:
    """What faults do to a vehicle during a step. gamma_dot_cap: the paper's unannounced slowdown; the others
    corrupt what it broadcasts: a frozen gamma sensor, a gamma offset, a skewed clock (s)."""

    gamma_dot_cap: float | None = None
    gamma_freeze: bool = False
    gamma_offset: float = 0.0
    clock_offset: float = 0.0


def receive(state: VehicleState, sender: int, estimate: NeighbourEstimate) -> VehicleState:
    """Take in one neighbour message; a stale one leaves the state as it is."""
    if not newer(state.estimates.get(sender), estimate):
        return state
    return replace(state, estimates={**state.estimates, sender: estimate})


def _neighbour_values(
    cfg: VehicleConfig, state: VehicleState, t: float, neighbours: Iterable[int]
) -> list[tuple[float, float]]:
    """Predicted (gamma_j, gamma_dot_j) of the neighbours heard from so far; unheard ones do not count."""
    held = state.estimates
    v_r = cfg.coordination.v_r
    return [predict(held[j], t, cfg.predictor, v_r) for j in neighbours if j in held]


def _closed_loop(
    cfg: VehicleConfig,
    state: VehicleState,
    t: float,
    z: FloatArray,
    neighbours: Sequence[int],
    dist: Disturbances,
) -> tuple[FloatArray, PathFollowingOutput, float]:
    """Derivative of z = [x, gamma, gamma_dot], with the controller outputs and v_tilde that produced it."""
    n = cfg.model.state_size
    x, gamma, gamma_dot = z[:n], float(z[n]), float(z[n + 1])
    cap = dist.gamma_dot_cap
    if cap is not None:
        gamma_dot = min(gamma_dot, cap)
    v_tilde = correction(gamma, gamma_dot, _neighbour_values(cfg, state, t, neighbours), cfg.coordination)
    out = path_following(
        cfg.model,
        cfg.params,
        cfg.path_following,
        cfg.path,
        x,
        gamma,
        gamma_dot,
        cfg.coordination.v_r,
        v_tilde,
        cfg.constants,
    )
    gamma_ddot = out.gamma_ddot
    if cap is not None and gamma_dot >= cap:
        gamma_ddot = min(gamma_ddot, 0.0)  # held at the cap: no wind-up
    zdot = np.empty(n + 2)
    zdot[:n] = cfg.model.derivative_from(x, *cfg.model.with_input(*out.drift, out.tau, cfg.params))
    zdot[n] = gamma_dot
    zdot[n + 1] = gamma_ddot
    return zdot, out, v_tilde


def step(
    cfg: VehicleConfig,
    state: VehicleState,
    dt: float,
    neighbours: Sequence[int],
    dist: Disturbances = Disturbances(),
) -> tuple[VehicleState, Telemetry]:
    """Advance one RK4 step of dt; the telemetry describes the state at the start of the step."""
    n = cfg.model.state_size
    t = state.t
    z = np.concatenate((state.x, (state.gamma, state.gamma_dot)))
    k1, out, v_tilde = _closed_loop(cfg, state, t, z, neighbours, dist)
    k2 = _closed_loop(cfg, state, t + dt / 2, z + dt / 2 * k1, neighbours, dist)[0]
    k3 = _closed_loop(cfg, state, t + dt / 2, z + dt / 2 * k2, neighbours, dist)[0]
    k4 = _closed_loop(cfg, state, t + dt, z + dt * k3, neighbours, dist)[0]
    z_next = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    gamma_dot_next = float(z_next[n + 1])
    if dist.gamma_dot_cap is not None:
        gamma_dot_next = min(gamma_dot_next, dist.gamma_dot_cap)
    telemetry = Telemetry(
        cfg.vehicle_id, t, state.gamma, float(z[n + 1]), state.x, out.error, out.tau, v_tilde, out.lyapunov
    )
    next_state = replace(
        state, t=t + dt, x=cfg.model.normalize(z_next[:n]), gamma=float(z_next[n]), gamma_dot=gamma_dot_next
    )
    return next_state, telemetry


def own_estimate(state: VehicleState) -> NeighbourEstimate:
    """What this vehicle tells its neighbours about itself now."""
    return NeighbourEstimate(state.gamma, state.gamma_dot, state.t)

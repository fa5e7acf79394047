"""One vehicle's whole closed loop as pure functions: dynamics + path following + coordination + estimates.

`step` advances a VehicleState by one fixed step with classical Runge-Kutta 4 and returns the telemetry at the start
of the step. Both engines call exactly this: the in-process engine for every vehicle in a loop, the vehicle process
once per sync step. Neighbour data enter only through `receive`, so what a vehicle knows is explicit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import msgspec
import numpy as np

from comms.records.records import Disturbances, FloatArray
from numerics.lanes import least
from vehicles.actuators import SIZE as ACTUATOR_SIZE
from vehicles.actuators import START as ACTUATOR_START
from vehicles.actuators import Actuators
from vehicles.coordination import CoordinationGains, CoordinationLaw, Corrected
from vehicles.current import Current, feedforward
from vehicles.current_observer import CurrentObserver
from vehicles.current_observer import feedforward as estimated_current
from vehicles.dynamics import LIFTED_SIZE, Model, PathVectors, reorthonormalize
from vehicles.estimates import FirstOrder, NeighbourEstimate, Predictor, fresh, newer
from vehicles.geometry import Float3
from vehicles.navigation import HeldError, NavParams, seen
from vehicles.params import VehicleParams
from vehicles.path_following import AdaptiveController, ControlOutput, PathFollowingController, is_adaptive
from vehicles.paths import Path
from vehicles.plant import plant_rates
from vehicles.saturation import bounded_correction, clamp, hold, slope_rate_bound, slope_size
from vehicles.stepping import Begun, Stepped
from vehicles.vehicle_model import Auv, VehicleModel

# Where gamma and gamma_dot sit in the integrated vector z = [lifted x, gamma, gamma_dot, actuators' state (if
# any), current observer's state (if any)].
_GAMMA, _GAMMA_DOT, _ACTUATORS = LIFTED_SIZE, LIFTED_SIZE + 1, LIFTED_SIZE + 2
UNDISTURBED = Disturbances()  # no fault acts on the vehicle


@dataclass(frozen=True, slots=True)
class VehicleConfig:
    vehicle_id: int
    model: Model
    params: VehicleParams
    path: Path
    controller: PathFollowingController  # vehicles.path_following: tau and gamma_ddot from the state and the path
    coordination: CoordinationGains
    predictor: Predictor = field(default_factory=FirstOrder)  # vehicles.estimates: how neighbours are predicted
    law: CoordinationLaw = field(default_factory=Corrected)  # vehicles.coordination: v_tilde from them
    max_age: float | None = None  # s after which a neighbour's estimate stops counting (None: never)
    # The plant where it is not the controller's model (vehicles.plant): params are then the controller's nominal
    # ones, plant the true ones (None: the same); the ocean current (None: still water) and whether the controller
    # knows it.
    plant: VehicleParams | None = None
    current: Current | None = None
    current_known: bool = False
    navigation: NavParams | None = None  # None: the controller sees the true state
    top_speed: float | None = None  # m/s along the path: bounds |gamma_dot| (vehicles.saturation); None: unbounded
    correction_limit: float | None = None  # v_tilde -> c tanh(v_tilde / c) (vehicles.saturation); None: as law (5)
    # m/s^2 the correction may accelerate the path's point by: v_tilde bounded by it / |p_d^gamma| (None: no bound)
    correction_acceleration: float | None = None
    # The vehicle model (vehicles.vehicle_model) whose parameters are params: its dynamics drive the controller's
    # inversion and the plant (None: the AUV of eqs. (1)-(2)); `vehicle` is the one in use.
    vehicle_model: VehicleModel | None = None
    # The on-board current estimate fed to the controller (vehicles.current_observer; None: none). A current the
    # controller is told (current_known) takes its place.
    current_observer: CurrentObserver | None = None
    actuators: Actuators | None = None  # fins and propeller between the controller and the plant (None: ideal)
    vehicle: VehicleModel = field(init=False)
    adaptive: AdaptiveController | None = field(init=False)  # the controller if it has a memory, else None

    def __post_init__(self) -> None:
        default = Auv(dimension=self.model.dim)  # only its dynamics count: the parameters are given
        object.__setattr__(self, "vehicle", self.vehicle_model or default)
        adaptive = self.controller if is_adaptive(self.controller) else None
        object.__setattr__(self, "adaptive", adaptive)


class VehicleState(msgspec.Struct, frozen=True):
    t: float
    x: FloatArray  # dynamic state of the model (see vehicles.dynamics)
    gamma: float
    gamma_dot: float
    estimates: Mapping[int, NeighbourEstimate] = msgspec.field(default_factory=dict)
    observer: tuple[float, ...] = ()  # the current observer's state (vehicles.current_observer); () before it starts
    memory: object = None  # an adaptive controller's (vehicles.path_following.AdaptiveController); None: none yet
    actuators: tuple[float, ...] = ()  # the actuators' state (vehicles.actuators); () before they start or if ideal


class Telemetry(msgspec.Struct, frozen=True):
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
    current_estimate: Float3 | None = None  # the observer's current, inertial, m/s (None: no observer)


def receive(state: VehicleState, sender: int, estimate: NeighbourEstimate) -> VehicleState:
    """Take in one neighbour message; a stale one leaves the state as it is."""
    if not newer(state.estimates.get(sender), estimate):
        return state
    # The constructor, not msgspec.structs.replace: the same object, at a fraction of the cost (per message per step).
    return VehicleState(
        state.t, state.x, state.gamma, state.gamma_dot, {**state.estimates, sender: estimate}, state.observer,
        state.memory, state.actuators,
    )  # fmt: skip


def neighbour_values(
    cfg: VehicleConfig, state: VehicleState, t: float, neighbours: Iterable[int]
) -> list[tuple[float, float]]:
    """Predicted (gamma_j, gamma_dot_j) of the neighbours heard from so far; unheard ones, and those not heard for
    longer than max_age, do not count."""
    held = state.estimates
    v_r, predictor, max_age = cfg.coordination.v_r, cfg.predictor, cfg.max_age
    if max_age is None:
        return [predictor.predict(held[j], t, v_r) for j in neighbours if j in held]
    return [predictor.predict(held[j], t, v_r) for j in neighbours if j in held and fresh(held[j], t, max_age)]


class Along:
    """What a stage needs of a vehicle's own path and of its neighbours' predicted (gamma_j, gamma_dot_j) at the
    stage's time (neighbour_values): the path's point as the model sees it and the coordination law's v_tilde.
    vehicles.lanes has the same for many vehicles at once."""

    __slots__ = ("cfg", "heard")

    def __init__(self, cfg: VehicleConfig, heard: list[tuple[float, float]]) -> None:
        self.cfg, self.heard = cfg, heard

    def point(self, gamma: float) -> PathVectors:
        return self.cfg.model.path_seen(self.cfg.path.evaluate_floats(gamma))

    def correction(self, gamma: float, gamma_dot: float) -> float:
        cfg = self.cfg
        return cfg.law.correction(gamma, gamma_dot, self.heard, cfg.coordination)


def _closed_loop(
    cfg: VehicleConfig,
    z: Sequence[float],
    along: Along,
    dist: Disturbances,
    t: float,
    held: HeldError | None = None,
    memory: object = None,
) -> tuple[list[float], ControlOutput, float, Float3, Float3]:
    """Derivative of z (see _GAMMA) at the stage's time t, with the controller's outputs, v_tilde, the error
    p - p_d(gamma) the controller saw [m] and the inputs the vehicle got; along: the path and the neighbours at t;
    held: the navigation error the controller sees the stage state with (None: it sees the truth); memory: an
    adaptive controller's, of the step's start. Written so that every float may be an array of lanes (many
    vehicles at once: vehicles.lanes), its branches on the state in functions that take both."""
    gamma, gamma_dot = z[_GAMMA], z[_GAMMA_DOT]
    point = along.point(gamma)
    limits = _rate_limits(cfg, dist, point)
    if limits is not None:
        gamma_dot = clamp(gamma_dot, *limits)
    v_tilde = _bounded(cfg, point, along.correction(gamma, gamma_dot))
    view = z if held is None else seen(z, held)
    known, observer_rates = _current_fed(cfg, z, view, t)
    vehicle, v_r, adaptive = cfg.vehicle, cfg.coordination.v_r, cfg.adaptive
    if adaptive is None:
        out = cfg.controller.control(vehicle, cfg.params, view, point, gamma, gamma_dot, v_r, known)
    else:
        out = adaptive.control_with(memory, vehicle, cfg.params, view, point, gamma, gamma_dot, v_r, known)
    gamma_ddot = out.gamma_ddot + v_tilde  # eq. (3): the controller's part, then the coordination's
    if limits is not None:
        gamma_ddot = hold(gamma_ddot, gamma_dot, *limits)  # held at a limit: no wind-up
    # The controller's drift is of the state it sees, with its nominal parameters (ControlOutput.drift: None where it
    # computed it with others, as the supervisor with its estimates): the plant's own when it sees the truth of a
    # nominal plant (no current: plant_rates is then the plain kinematics), else the plant computes its own.
    own = out.drift if cfg.plant is None and held is None else None
    applied, actuator_rates = _actuated(cfg, z, out.tau)
    xdot = plant_rates(vehicle, cfg.plant or cfg.params, cfg.current, t, z, own, applied)
    p_d = point[0]
    zdot = [*xdot, gamma_dot, gamma_ddot, *actuator_rates, *observer_rates]
    return zdot, out, v_tilde, (view[0] - p_d[0], view[1] - p_d[1], view[2] - p_d[2]), applied


def _actuated(cfg: VehicleConfig, z: Sequence[float], commanded: Float3) -> tuple[Float3, tuple[float, ...]]:
    """The inputs the vehicle gets for those commanded, and the actuators' rates (() if ideal): the fins' lift
    follows the true speed through the water (z's surge)."""
    actuators = cfg.actuators
    if actuators is None:
        return commanded, ()
    a, u = z[_ACTUATORS : _ACTUATORS + ACTUATOR_SIZE], z[12]
    return actuators.applied(a, u), actuators.rates(a, commanded, u)


def _observer_at(cfg: VehicleConfig) -> int:
    """Where the current observer's state starts in z."""
    return _ACTUATORS + (0 if cfg.actuators is None else ACTUATOR_SIZE)


def _current_fed(
    cfg: VehicleConfig, z: Sequence[float], view: Sequence[float], t: float
) -> tuple[tuple[Float3, Float3] | None, tuple[float, ...]]:
    """The current the controller is fed, (c, c_dot) in body axes (None: it steers as in still water): the one it is
    told, or its observer's estimate; and the observer's rates (() without one)."""
    if cfg.current_known and cfg.current is not None:
        return feedforward(cfg.current, t, view), ()
    observer = cfg.current_observer
    if observer is None:
        return None, ()
    estimate = z[_observer_at(cfg) :]
    rates = observer.rates(view, estimate)
    return estimated_current(view, estimate, rates), rates


def _bounded(cfg: VehicleConfig, point: PathVectors, v_tilde: float) -> float:
    """The law's correction within the [saturation] bounds: a given c, and what the vehicle's thrust allows at the
    path point (as the model sees it) where the vehicle's gamma is."""
    if cfg.correction_limit is not None:
        v_tilde = bounded_correction(v_tilde, cfg.correction_limit)
    if cfg.correction_acceleration is not None:
        size = slope_size(point)
        if isinstance(size, np.ndarray):  # lanes: the same, lane by lane
            moving = size > 0.0
            bounded = bounded_correction(v_tilde, cfg.correction_acceleration / np.where(moving, size, 1.0))
            return np.where(moving, bounded, v_tilde)
        if size > 0.0:  # where the path does not move with gamma, nothing to bound
            v_tilde = bounded_correction(v_tilde, cfg.correction_acceleration / size)
    return v_tilde


def _rate_limits(cfg: VehicleConfig, dist: Disturbances, point: PathVectors | None) -> tuple[float, float] | None:
    """The interval gamma_dot is held in (None: unbounded): the speed_cap fault's cap (>= 0) from above and the top
    speed's bound (vehicles.saturation.rate_bound) both ways, at the path point of gamma as the model sees it (needed
    with a top speed only). One interval, so clamping and holding the integrator at it is the same as at each in
    turn."""
    cap = dist.gamma_dot_cap
    if cfg.top_speed is None or point is None:
        return None if cap is None else (-math.inf, cap)
    bound = slope_rate_bound(slope_size(point), cfg.top_speed)
    return -bound, bound if cap is None else least(cap, bound)


def _advance(z: Sequence[float], h: float, zdot: Sequence[float]) -> list[float]:
    """z + h zdot, elementwise (an RK4 stage point)."""
    return [a + h * b for a, b in zip(z, zdot, strict=True)]


def step(
    cfg: VehicleConfig,
    state: VehicleState,
    dt: float,
    neighbours: Sequence[int],
    dist: Disturbances = UNDISTURBED,
    held: HeldError | None = None,
) -> tuple[VehicleState, Telemetry]:
    """Advance one RK4 step of dt; the telemetry describes the state at the start of the step.

    Integrated in floats on the lifted state (vehicles.dynamics): arrays only at the boundary. held: the navigation
    error the controller sees every stage with (vehicles.navigation); the telemetry's error is the true one.
    vehicles.lanes steps many vehicles at once through the same begin, rk4 and finish."""
    begun = begin(cfg, state, held)

    def along(t: float) -> Along:
        return Along(cfg, neighbour_values(cfg, state, t, neighbours))

    return finish(cfg, state, begun, rk4(cfg, state.t, begun, dt, along, dist, held), dt, dist, held)


def begin(cfg: VehicleConfig, state: VehicleState, held: HeldError | None) -> Begun:
    """The integrated vector of the state and what the controller and the observer start the step from."""
    lifted = cfg.model.lift(state.x)
    actuated = state.actuators or (ACTUATOR_START if cfg.actuators is not None else ())
    observer = _observer_state(cfg, state, lifted, held)
    z = [*lifted, float(state.gamma), float(state.gamma_dot), *actuated, *observer]
    return Begun(z, _memory(cfg, state, lifted, held), observer)


def finish(
    cfg: VehicleConfig, state: VehicleState, begun: Begun, stepped: Stepped, dt: float, dist: Disturbances,
    held: HeldError | None,
) -> tuple[VehicleState, Telemetry]:  # fmt: skip
    """The state after the step (its attitude back on SO(3), gamma_dot within its limits) and the telemetry of its
    start."""
    model, z, z_next, observer = cfg.model, begun.z, stepped.z, begun.observer
    error = stepped.seen_error if held is None else _true_error(stepped.seen_error, held)
    observed = (observer[3], observer[4], observer[5]) if observer else None
    telemetry = Telemetry(
        cfg.vehicle_id, state.t, state.gamma, z[_GAMMA_DOT], state.x, model.vector(error),
        model.inputs(stepped.applied), stepped.v_tilde, stepped.lyapunov, observed,
    )  # fmt: skip
    x_next = model.lower(reorthonormalize(z_next[:LIFTED_SIZE]))
    gamma_dot_next = _within_limits(cfg, dist, z_next[_GAMMA], z_next[_GAMMA_DOT])
    at = _observer_at(cfg)
    actuated_next, observer_next = tuple(z_next[_ACTUATORS:at]), tuple(z_next[at:])
    next_state = VehicleState(
        state.t + dt, x_next, z_next[_GAMMA], gamma_dot_next, state.estimates, observer_next, stepped.memory,
        actuated_next,
    )  # fmt: skip
    return next_state, telemetry


def rk4(
    cfg: VehicleConfig, t: float, begun: Begun, dt: float, along: Callable[[float], Along], dist: Disturbances,
    held: HeldError | None,
) -> Stepped:  # fmt: skip
    """One classical RK4 step of dt from begun at t; along(t): the path and the neighbours at a stage's time."""
    z, memory = begun.z, begun.memory
    # The estimates do not change within a step: the two midpoint stages predict the neighbours at the same time.
    mid = along(t + dt / 2)
    k1, out, v_tilde, seen_error, tau = _closed_loop(cfg, z, along(t), dist, t, held, memory)
    z2 = _advance(z, dt / 2, k1)
    k2, _, _, _, tau2 = _closed_loop(cfg, z2, mid, dist, t + dt / 2, held, memory)
    z3 = _advance(z, dt / 2, k2)
    k3, _, _, _, tau3 = _closed_loop(cfg, z3, mid, dist, t + dt / 2, held, memory)
    end = along(t + dt)
    z4 = _advance(z, dt, k3)
    k4, _, _, _, tau4 = _closed_loop(cfg, z4, end, dist, t + dt, held, memory)
    h = dt / 6
    z_next = [a + h * (b1 + 2 * b2 + 2 * b3 + b4) for a, b1, b2, b3, b4 in zip(z, k1, k2, k3, k4, strict=True)]
    stages = [(z, tau), (z2, tau2), (z3, tau3), (z4, tau4)]
    return Stepped(z_next, _learned(cfg, memory, stages, z_next, dt, held), v_tilde, seen_error, out.lyapunov, tau)


def _memory(cfg: VehicleConfig, state: VehicleState, lifted: Sequence[float], held: HeldError | None) -> object:
    """An adaptive controller's memory for this step: the state's, or its start from what it sees now if it has
    none yet (a new or restarted vehicle); None for a controller without one."""
    adaptive = cfg.adaptive
    if adaptive is None:
        return None
    if state.memory is not None:
        return state.memory
    return adaptive.start(cfg.vehicle, cfg.params, lifted if held is None else seen(lifted, held))


def _learned(
    cfg: VehicleConfig, memory: object, stages: Sequence[tuple[list[float], Float3]], z_next: Sequence[float],
    dt: float, held: HeldError | None,
) -> object:  # fmt: skip
    """An adaptive controller's memory after the step: from the RK4 stages it steered at (the inputs the vehicle got
    there) and the state at the step's end, as it saw them (with the step's navigation error)."""
    adaptive = cfg.adaptive
    if adaptive is None:
        return None
    after = z_next[:LIFTED_SIZE]
    steered = [(z[:LIFTED_SIZE], tau) for z, tau in stages]
    if held is not None:
        after, steered = seen(after, held), [(seen(s, held), tau) for s, tau in steered]
    return adaptive.update(memory, cfg.vehicle, cfg.params, steered, after, dt)


def _within_limits(cfg: VehicleConfig, dist: Disturbances, gamma: float, gamma_dot: float) -> float:
    """gamma_dot clamped to the interval it is held in at gamma (_rate_limits)."""
    point = None if cfg.top_speed is None else cfg.model.path_seen(cfg.path.evaluate_floats(gamma))
    limits = _rate_limits(cfg, dist, point)
    return gamma_dot if limits is None else clamp(gamma_dot, *limits)


def _observer_state(
    cfg: VehicleConfig, state: VehicleState, lifted: Sequence[float], held: HeldError | None
) -> tuple[float, ...]:
    """The current observer's state to integrate: the state's own, or the observer's start from what the controller
    sees now if it has none yet (a new or restarted vehicle); () without an observer, or when the current is told."""
    observer = cfg.current_observer
    if observer is None or (cfg.current_known and cfg.current is not None):
        return ()
    if state.observer:
        return state.observer
    return observer.initial(lifted if held is None else seen(lifted, held))


def _true_error(error: Sequence[float], held: HeldError) -> tuple[float, float, float]:
    """p - p_d from the error the controller saw, p_hat - p_d: path following is judged against the truth."""
    ex, ey, ez = held.position
    return error[0] - ex, error[1] - ey, error[2] - ez


def own_estimate(state: VehicleState) -> NeighbourEstimate:
    """What this vehicle tells its neighbours about itself now."""
    return NeighbourEstimate(state.gamma, state.gamma_dot, state.t)

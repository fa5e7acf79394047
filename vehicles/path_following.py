"""Path-following controller for an underactuated AUV: the delta-shifted backstepping design.

After Aguiar & Hespanha, "Trajectory-tracking and path-following of underactuated autonomous vehicles with
parametric modeling uncertainty" (IEEE TAC 52(8), 2007). z1 = 0 puts the path point p_d at p - R delta: the
controlled point is -delta along the body x axis, ahead of the vehicle for delta < 0 (delta = -1: 1 m ahead, so
the vehicle trails its path point by |delta|), and the surge force and the pitch and yaw torques can steer it in
every direction:

    z1 = R'(p - p_d(gamma)) - delta,   rho = sqrt(1 + |z1|^2),   sigma = z1 / rho
    alpha = Delta^-1 (-K1 sigma - nu_u + R' p_d^gamma v_d)            virtual (u, q, r)
    z2 = nu_c - alpha,    nu_c_dot := alpha_dot - Delta' sigma - K2 z2  (through the model's inverse)
    gamma_ddot = -k_zeta (gamma_dot - v_d) + sigma' R' p_d^gamma + v_tilde   (paper's eq. (3), as gamma_ddot)

V = (rho - 1) + zeta^2 / 2 + |z2|^2 / 2 has V_dot = -sigma' K1 sigma - k_zeta zeta^2 - z2' K2 z2 + zeta v_tilde,
so with no coordination input and no saturation V never increases, and the vehicle converges to the tube
|p - p_d| -> |delta| around its path.

Damping. Inverting the model exactly ("cancel") cancels the nominal damping D(nu_c) nu_c of the measured velocity;
where the true vehicle has less damping than its model (the angular quadratic terms are the least known), the
difference acts as anti-damping that grows as |nu_c|^2 and beats the linear K2 feedback above a rate (about
0.18 rad/s in issue 24's runs). "feedforward" (the default) feeds the nominal damping forward at the virtual
velocity alpha instead, D(alpha) alpha, and leaves the true vehicle's own damping on the measured one: on the z2
error it then acts as D_true(nu_c) nu_c - D_true(alpha) alpha, which has the sign of z2 for any positive damping
(x -> D(x) x is increasing), plus the bounded mismatch (D_nominal - D_true)(alpha) alpha; the nominal V_dot gains
-z2' J^-1 (D(nu_c) nu_c - D(alpha) alpha) <= 0, so V still never increases. A damping term is a useful
nonlinearity, one a Lyapunov design need not cancel (Krstic, Kanellakopoulos & Kokotovic, Nonlinear and Adaptive
Control Design, Wiley 1995). `law` writes the controller once, in floats on the lifted state (see vehicles.dynamics),
for the spatial and the planar model; `path_following` is its array interface.

A controller is any object with the `PathFollowingController` interface; the built-in `Backstepping` is registered
under the entry-point group `cpf.controllers` like any extension (docs/extending.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Literal, NamedTuple, Protocol, runtime_checkable

import numpy as np
from annotated_types import Gt

from comms.records.records import FloatArray
from numerics.lanes import sqrt
from vehicles.dynamics import Accelerations, Model, PathVectors, with_inputs
from vehicles.geometry import Float3
from vehicles.params import VehicleParams
from vehicles.paths import Path
from vehicles.saturation import within
from vehicles.vehicle_model import Auv, VehicleModel

Current = tuple[Float3, Float3]  # (c, c_dot): the ocean current in body axes, m/s, and its derivative, m/s^2
Stage = tuple[Sequence[float], Float3]  # an RK4 stage as the controller steered at it: (the lifted state seen, tau)
STAGE_WEIGHTS = (1 / 6, 1 / 3, 1 / 3, 1 / 6)  # how classical RK4 averages its four stages' rates over a step


def stage_mean(model: VehicleModel, params: VehicleParams, stages: Sequence[Stage]) -> list[float]:
    """The model's accelerations (u, v, w, p, q, r rows) with each stage's inputs, averaged as RK4 averages its
    stages: on a plant with these parameters, exactly step_mean over the step."""
    mean = [0.0] * 6
    for w, (s, tau) in zip(STAGE_WEIGHTS, stages, strict=True):
        mean = [m + w * a for m, a in zip(mean, accelerations(model, params, s, tau), strict=True)]
    return mean


def step_mean(before: Sequence[float], after: Sequence[float], dt: float) -> list[float]:
    """The accelerations (u, v, w, p, q, r rows) a step of dt shows: (nu(t + dt) - nu(t)) / dt."""
    return [(a - b) / dt for a, b in zip(after[12:18], before[12:18], strict=True)]


def accelerations(model: VehicleModel, params: VehicleParams, s: Sequence[float], tau: Float3) -> tuple[float, ...]:
    """The model's accelerations (u, v, w, p, q, r rows) at the lifted state s with inputs tau."""
    linear, angular = with_inputs(model.drift(s, params), tau, params)
    return (*linear, *angular)


class ControlOutput(NamedTuple):
    """What a path-following controller gives at one evaluation (an RK4 stage)."""

    tau: Float3  # (tau_u [N], tau_q [N m], tau_r [N m]) within the vehicle's limits; a planar vehicle's tau_q is 0
    gamma_ddot: float  # path-parameter acceleration without the coordination correction, unit of gamma per s^2
    lyapunov: float  # the value of its Lyapunov function (the built-in's: V above), recorded in every state message
    drift: Accelerations | None  # model.drift(s, params) if it computed it (the plant then reuses it), else None


@runtime_checkable
class PathFollowingController(Protocol):
    """What a path-following controller computes for one vehicle at one RK4 stage (four times a step).

    control(model, params, s, path, gamma, gamma_dot, v_d, current) -> ControlOutput, with
    - model: the vehicle model (vehicles.vehicle_model.VehicleModel): model.drift(s, params) gives its accelerations
      with no input ((v_dot [m/s^2], omega_dot [rad/s^2]), body axes), model.dimension 3 or 2 (planar);
    - params: the vehicle's nominal parameters (vehicles.params.VehicleParams: masses, damping, limits, SI units);
    - s: the state the controller sees (navigation may blur it), 18 floats in the spatial layout of
      vehicles.dynamics: p [m] (inertial, z up), R (body to inertial, row-major), v [m/s], omega [rad/s] (body axes);
      a planar vehicle's has z = 0 and no heave, roll or pitch;
    - path: (p_d, dp_d/dgamma, d2p_d/dgamma2) at gamma, in m, m per unit of gamma, m per unit of gamma^2 (inertial;
      a planar vehicle sees their horizontal projection);
    - gamma [unit of gamma], gamma_dot [unit of gamma per s]: the path parameter and its rate;
    - v_d: the desired rate of gamma, the fleet's v_r [unit of gamma per s];
    - current: (c, c_dot), the ocean current in body axes and its derivative if the scenario makes it known to the
      controller, or else the vehicle's on-board estimate of it (vehicles.current_observer) if it runs one, else None.
    gamma_ddot is the paper's eq. (3) without the coordination term: the fleet adds v_tilde (docs/extending.md).
    Must be pure (the same result for the same arguments) and return finite numbers."""

    def control(
        self, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors, gamma: float,
        gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput: ...  # fmt: skip


@runtime_checkable
class AdaptiveController(Protocol):
    """A path-following controller with a memory it learns from (vehicles.supervisory's estimators and switching
    logic, an adaptive law's parameter estimates): the memory is any immutable value, made once when the vehicle
    starts (or restarts) and replaced after every step, and the vehicle's state carries it between steps.

    - start(model, params, s) -> memory: its memory for a vehicle that starts at the lifted state s it sees;
    - control_with(memory, model, params, s, path, gamma, gamma_dot, v_d, current) -> ControlOutput: as `control`
      (PathFollowingController), with the memory of the step's start; called at every RK4 stage instead of it;
    - update(memory, model, params, stages, after, dt) -> memory: after a step of dt, from the four RK4 stages it
      steered at, (lifted state it saw, tau [N, N m, N m]) each, which the step averages with the weights STAGE_WEIGHTS
      (stages[0][0] is the state at the step's start), and the state it sees at the step's end (after; the same
      navigation error as the stages').
    All three pure: the same memory in every engine, in every hosting, after a restart."""

    def start(self, model: VehicleModel, params: VehicleParams, s: Sequence[float]) -> object: ...

    def control_with(
        self, memory: object, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors,
        gamma: float, gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput: ...  # fmt: skip

    def update(
        self, memory: object, model: VehicleModel, params: VehicleParams, stages: Sequence[Stage],
        after: Sequence[float], dt: float,
    ) -> object: ...  # fmt: skip


def is_adaptive(controller: object) -> bool:
    """Whether a controller has a memory (AdaptiveController); a guarded extension says so for what it guards."""
    return isinstance(controller, AdaptiveController) and bool(getattr(controller, "adaptive", True))


@dataclass(frozen=True, slots=True)
class Backstepping:
    """The delta-shifted backstepping controller of the module docstring (entry point `backstepping`): delta in m
    (non-zero; its size is the tube radius), k1 in m/s, k2 and k_zeta in 1/s; damping: how the model's damping of
    the actuated velocities (u, q, r) enters the inputs, "feedforward" (the default) or "cancel" (the former
    default; see the module docstring)."""

    delta: float = -1.0
    k1: Annotated[float, Gt(0)] = 0.5
    k2: Annotated[float, Gt(0)] = 1.0
    k_zeta: Annotated[float, Gt(0)] = 1.0
    damping: Literal["feedforward", "cancel"] = "feedforward"

    def __post_init__(self) -> None:
        if self.delta == 0.0:
            raise ValueError("delta must be non-zero (delta = 0 leaves the pitch and yaw rates unsteerable)")

    @property
    def lanes(self) -> bool:
        """Whether control takes arrays of lanes (vehicles.lanes): this class's does (law is written in their
        arithmetic); a subclass with a control of its own says so itself (a class attribute lanes = True)."""
        return type(self).control is Backstepping.control

    def control(
        self, model: VehicleModel, params: VehicleParams, s: Sequence[float], path: PathVectors, gamma: float,
        gamma_dot: float, v_d: float, current: Current | None,
    ) -> ControlOutput:  # fmt: skip
        return law(self, model, params, s, path, gamma_dot, v_d, current)[0]


@dataclass(frozen=True, slots=True)
class PathFollowingOutput:
    tau: FloatArray  # saturated inputs
    gamma_ddot: float  # path-parameter acceleration, coordination correction included
    error: FloatArray  # p - p_d(gamma), inertial frame, m
    z1: FloatArray  # shifted error, body frame, m
    lyapunov: float  # V of the module docstring
    drift: tuple[FloatArray, FloatArray]  # (v_dot, omega_dot) with no input: the model adds tau's part


def path_following(
    model: Model,
    prm: VehicleParams,
    gains: Backstepping,
    path: Path,
    x: FloatArray,
    gamma: float,
    gamma_dot: float,
    v_d: float,
    correction: float,
) -> PathFollowingOutput:
    """Inputs and gamma_ddot for state x on path at gamma, desired speed v_d (constant) plus correction: `law` on
    arrays (the closed loop calls the controller's `control` on floats)."""
    s, seen = model.lift(x), model.path_seen(path.evaluate_floats(gamma))
    out, z1 = law(gains, Auv(dimension=model.dim), prm, s, seen, gamma_dot, v_d, None)
    assert out.drift is not None
    v_dot0, w_dot0 = out.drift
    error = (s[0] - seen[0][0], s[1] - seen[0][1], s[2] - seen[0][2])
    return PathFollowingOutput(
        model.inputs(out.tau), out.gamma_ddot + correction, model.vector(error), model.vector(z1), out.lyapunov,
        (model.vector(v_dot0), model.angular(w_dot0)),
    )  # fmt: skip


def law(
    gains: Backstepping,
    model: VehicleModel,
    prm: VehicleParams,
    s: Sequence[float],
    path: PathVectors,
    gamma_dot: float,
    v_d: float,
    current: Current | None = None,
) -> tuple[ControlOutput, Float3]:
    """The law of the module docstring for a lifted state s (vehicles.dynamics), in floats, and its z1.

    Written once, in 3-D, for both models: the actuated velocities are (u, q, r), so
        Delta = [[1, 0, 0], [0, 0, -delta], [0, delta, 0]],   nu_c = (u, q, r),   nu_u = (0, v, w).
    A planar vehicle's lifted state has no heave, roll or pitch rate (w = p = q = 0) and it sees its path's horizontal
    projection, so the out-of-plane rows are exact zeros (tau_q = 0) and the in-plane ones are the planar law with
    Delta = [[1, 0], [0, -delta]]. One helper, not more: this runs at every RK4 stage.

    current: (c, c_dot), the ocean current in body axes and its derivative, for a controller that knows it (the
    law on the velocity over ground: _over_ground); None for one that does not."""
    z1, tangent, curvature = _path_in_body(path, s, gains.delta)
    rho = sqrt(1.0 + z1[0] * z1[0] + z1[1] * z1[1] + z1[2] * z1[2])
    sigma = (z1[0] / rho, z1[1] / rho, z1[2] / rho)
    drift = model.drift(s, prm)  # with zero input: exact for the unactuated velocities, the rest is tau's to add
    if current is None:
        z2, tau = _backstepping(gains, prm, s, z1, sigma, rho, tangent, curvature, drift, gamma_dot, v_d)
    else:
        ground, ground_drift = _over_ground(s, drift, current)
        z2, tau = _backstepping(gains, prm, ground, z1, sigma, rho, tangent, curvature, ground_drift, gamma_dot, v_d)
    zeta = gamma_dot - v_d
    along = sigma[0] * tangent[0] + sigma[1] * tangent[1] + sigma[2] * tangent[2]
    gamma_ddot = -gains.k_zeta * zeta + along  # the fleet adds v_tilde to this sum: eq. (3)'s order of terms
    lyapunov = (rho - 1.0) + 0.5 * zeta * zeta + 0.5 * (z2[0] * z2[0] + z2[1] * z2[1] + z2[2] * z2[2])
    return ControlOutput(tau, gamma_ddot, lyapunov, drift), z1


def _fed_forward(prm: VehicleParams, tau: Float3, alpha: Float3, nu_c: Float3) -> Float3:
    """Inputs that cancel the damping of nu_c = (u, q, r) made to feed it forward at alpha instead."""
    lin, quad, ang_lin, ang_quad = (
        prm.linear_damping, prm.quadratic_damping, prm.angular_linear_damping, prm.angular_quadratic_damping,
    )  # fmt: skip
    return (
        tau[0] + drag(lin[0], quad[0], alpha[0], nu_c[0]),
        tau[1] + drag(ang_lin[1], ang_quad[1], alpha[1], nu_c[1]),
        tau[2] + drag(ang_lin[2], ang_quad[2], alpha[2], nu_c[2]),
    )


def drag(linear: float, quadratic: float, wanted: float, measured: float) -> float:
    """D(wanted) wanted - D(measured) measured for D(x) = linear + quadratic |x|: what feeding the damping forward at
    the virtual velocity adds to inputs that cancel it at the measured one."""
    return (linear + quadratic * abs(wanted)) * wanted - (linear + quadratic * abs(measured)) * measured


def _path_in_body(path: PathVectors, s: Sequence[float], delta: float) -> tuple[Float3, Float3, Float3]:
    """z1 = R' (p - p_d) - delta, tangent = R' p_d^gamma, curvature = R' p_d^gammagamma."""
    p_d, p_g, p_gg = path
    error = (s[0] - p_d[0], s[1] - p_d[1], s[2] - p_d[2])
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = s[3:12]
    z1 = (
        r11 * error[0] + r21 * error[1] + r31 * error[2] - delta,
        r12 * error[0] + r22 * error[1] + r32 * error[2],
        r13 * error[0] + r23 * error[1] + r33 * error[2],
    )
    tangent = (r11 * p_g[0] + r21 * p_g[1] + r31 * p_g[2], r12 * p_g[0] + r22 * p_g[1] + r32 * p_g[2],
               r13 * p_g[0] + r23 * p_g[1] + r33 * p_g[2])  # fmt: skip
    curvature = (r11 * p_gg[0] + r21 * p_gg[1] + r31 * p_gg[2], r12 * p_gg[0] + r22 * p_gg[1] + r32 * p_gg[2],
                 r13 * p_gg[0] + r23 * p_gg[1] + r33 * p_gg[2])  # fmt: skip
    return z1, tangent, curvature


def _over_ground(
    s: Sequence[float], drift: Accelerations, current: tuple[Float3, Float3]
) -> tuple[list[float], Accelerations]:
    """The lifted state with its body velocity over ground (v + c) and the drift with c_dot added: what the law
    works on when it knows the current (the angular velocity and its drift are the same in both).

    Why: the state's velocity is relative to the water, so z1_dot = -S(omega) z1 + Delta nu_c + nu_u + c - tangent
    gamma_dot; the term c is cancelled by the virtual control alpha = Delta^-1 (-K1 sigma - nu_u - c + tangent v_d),
    whose derivative then carries -c_dot. That is the law evaluated on the velocity over ground, nu + c, with the
    acceleration over ground, nu_dot + c_dot; V_dot is as without a current. A controller that does not know c leaves
    + sigma' c in V_dot: the tube grows (see vehicles.current)."""
    (cx, cy, cz), (dcx, dcy, dcz) = current
    (du, dv, dw), angular = drift
    ground = [*s[0:12], s[12] + cx, s[13] + cy, s[14] + cz, *s[15:18]]
    return ground, ((du + dcx, dv + dcy, dw + dcz), angular)


def _backstepping(
    gains: Backstepping, prm: VehicleParams, s: Sequence[float], z1: Float3, sigma: Float3, rho: float,
    tangent: Float3, curvature: Float3, drift: Accelerations, gamma_dot: float, v_d: float,
) -> tuple[Float3, Float3]:  # fmt: skip
    """(z2, saturated tau): the virtual control alpha, its derivative (v_d constant), and the inputs that give
    nu_c_dot = alpha_dot - Delta' sigma - k2 z2 given the drift (curvature: R' p_d^gammagamma)."""
    (z1x, z1y, z1z), (sx, sy, sz), (tx, ty, tz) = z1, sigma, tangent
    u, v, w, p, q, r = s[12:18]
    k1, delta, inv_delta = gains.k1, gains.delta, 1.0 / gains.delta
    # z1_dot = -S(omega) z1 + Delta nu_c + nu_u - tangent gamma_dot; Delta nu_c + nu_u = (u, v - delta r, w + delta q)
    dz1x = -(q * z1z - r * z1y) + u - tx * gamma_dot
    dz1y = -(r * z1x - p * z1z) + (-delta * r + v) - ty * gamma_dot
    dz1z = -(p * z1y - q * z1x) + (delta * q + w) - tz * gamma_dot
    along = sx * dz1x + sy * dz1y + sz * dz1z
    dsx, dsy, dsz = (dz1x - sx * along) / rho, (dz1y - sy * along) / rho, (dz1z - sz * along) / rho  # sigma_dot
    # alpha = Delta^-1 (-k1 sigma - nu_u + tangent v_d), with Delta^-1 (a, b, c) = (a, c / delta, -b / delta)
    ay, az = -k1 * sy - v + ty * v_d, -k1 * sz - w + tz * v_d
    alpha_u, alpha_q, alpha_r = -k1 * sx + tx * v_d, inv_delta * az, -inv_delta * ay
    (du, dv, dw), (_, dq, dr) = drift
    # tangent_dot = -S(omega) tangent + R' p_d^gammagamma gamma_dot
    dtx = -(q * tz - r * ty) + curvature[0] * gamma_dot
    dty = -(r * tx - p * tz) + curvature[1] * gamma_dot
    dtz = -(p * ty - q * tx) + curvature[2] * gamma_dot
    day, daz = -k1 * dsy - dv + dty * v_d, -k1 * dsz - dw + dtz * v_d
    dalpha_u, dalpha_q, dalpha_r = -k1 * dsx + dtx * v_d, inv_delta * daz, -inv_delta * day
    # nu_c_dot = alpha_dot - Delta' sigma - k2 z2, Delta' sigma = (sigma_x, delta sigma_z, -delta sigma_y)
    k2 = gains.k2
    z2u, z2q, z2r = u - alpha_u, q - alpha_q, r - alpha_r
    m_u, j_q, j_r = prm.mass[0], prm.inertia[1], prm.inertia[2]  # how hard each input pushes its own velocity
    tau_u = m_u * (dalpha_u - sx - k2 * z2u - du)
    tau_q = j_q * (dalpha_q - delta * sz - k2 * z2q - dq)
    tau_r = j_r * (dalpha_r + delta * sy - k2 * z2r - dr)
    if gains.damping == "feedforward":  # the drift's damping of (u, q, r) moved from the measured to the virtual one
        tau_u, tau_q, tau_r = _fed_forward(prm, (tau_u, tau_q, tau_r), (alpha_u, alpha_q, alpha_r), (u, q, r))
    return (z2u, z2q, z2r), saturated(prm, tau_u, tau_q, tau_r)


def saturated(prm: VehicleParams, tau_u: float, tau_q: float, tau_r: float) -> Float3:
    """The inputs within the vehicle's limits: min(max(tau, -lim), lim) to the bit, NaN included, without six
    builtin calls per evaluation (lanes: vehicles.saturation.within)."""
    lim_u, lim_t = prm.max_surge_force, prm.max_torque
    if isinstance(tau_u, np.ndarray):
        return within(tau_u, lim_u), within(tau_q, lim_t), within(tau_r, lim_t)
    return (
        lim_u if tau_u > lim_u else -lim_u if tau_u < -lim_u else tau_u,
        lim_t if tau_q > lim_t else -lim_t if tau_q < -lim_t else tau_q,
        lim_t if tau_r > lim_t else -lim_t if tau_r < -lim_t else tau_r,
    )

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
|p - p_d| -> |delta| around its path. `control` writes the law once, in floats on the lifted state (see
vehicles.dynamics), for the spatial and the planar model; `path_following` is its array interface.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

from comms.records import FloatArray
from vehicles.dynamics import Accelerations, Model
from vehicles.geometry import Float3
from vehicles.params import VehicleParams
from vehicles.paths import Path


@dataclass(frozen=True, slots=True)
class PathFollowingGains:
    """delta in m (non-zero; its size is the tube radius), k1 in m/s, k2 and k_zeta in 1/s."""

    delta: float = -1.0
    k1: float = 0.5
    k2: float = 1.0
    k_zeta: float = 1.0


@dataclass(frozen=True, slots=True)
class PathFollowingOutput:
    tau: FloatArray  # saturated inputs
    gamma_ddot: float  # path-parameter acceleration, coordination correction included
    error: FloatArray  # p - p_d(gamma), inertial frame, m
    z1: FloatArray  # shifted error, body frame, m
    lyapunov: float  # V of the module docstring
    drift: tuple[FloatArray, FloatArray]  # (v_dot, omega_dot) with no input: the model adds tau's part


class Control(NamedTuple):
    """The controller's outputs in floats, in 3-D (a planar vehicle's: the restriction, see `control`)."""

    tau: Float3  # saturated (tau_u, tau_q, tau_r)
    gamma_ddot: float
    error: Float3
    z1: Float3
    lyapunov: float
    drift: Accelerations


@dataclass(frozen=True, slots=True)
class ControllerConstants:
    """What the controller uses at every evaluation and never changes for a vehicle: computed once."""

    gains: PathFollowingGains
    inverse_delta: float
    input_inertia: Float3  # how hard each input pushes its own actuated velocity: (m_u, J_q, J_r)
    limits: Float3  # |tau_u|, |tau_q|, |tau_r|

    @staticmethod
    def of(prm: VehicleParams, gains: PathFollowingGains) -> ControllerConstants:
        return ControllerConstants(
            gains, 1.0 / gains.delta, (prm.mass[0], prm.inertia[1], prm.inertia[2]),
            (prm.max_surge_force, prm.max_torque, prm.max_torque),
        )  # fmt: skip


def path_following(
    model: Model,
    prm: VehicleParams,
    gains: PathFollowingGains,
    path: Path,
    x: FloatArray,
    gamma: float,
    gamma_dot: float,
    v_d: float,
    correction: float,
) -> PathFollowingOutput:
    """Inputs and gamma_ddot for state x on path at gamma, desired speed v_d (constant) plus correction: `control`
    on arrays (the closed loop calls `control` with constants it computed once)."""
    c = ControllerConstants.of(prm, gains)
    out = control(model, prm, c, path, model.lift(x), gamma, gamma_dot, v_d, correction)
    v_dot0, w_dot0 = out.drift
    return PathFollowingOutput(
        model.inputs(out.tau), out.gamma_ddot, model.vector(out.error), model.vector(out.z1), out.lyapunov,
        (model.vector(v_dot0), model.angular(w_dot0)),
    )  # fmt: skip


def control(
    model: Model,
    prm: VehicleParams,
    c: ControllerConstants,
    path: Path,
    s: Sequence[float],
    gamma: float,
    gamma_dot: float,
    v_d: float,
    correction: float,
    current: tuple[Float3, Float3] | None = None,
) -> Control:
    """The law of the module docstring for a lifted state s (vehicles.dynamics), in floats.

    Written once, in 3-D, for both models: the actuated velocities are (u, q, r), so
        Delta = [[1, 0, 0], [0, 0, -delta], [0, delta, 0]],   nu_c = (u, q, r),   nu_u = (0, v, w).
    A planar vehicle's lifted state has no heave, roll or pitch rate (w = p = q = 0) and it sees its path's horizontal
    projection, so the out-of-plane rows are exact zeros (tau_q = 0) and the in-plane ones are the planar law with
    Delta = [[1, 0], [0, -delta]]. One helper, not more: this runs at every RK4 stage.

    current: (c, c_dot), the ocean current in body axes and its derivative, for a controller that knows it (the
    law on the velocity over ground: _over_ground); None for one that does not."""
    error, z1, tangent, curvature = _path_in_body(model, path, s, gamma, c.gains.delta)
    rho = math.sqrt(1.0 + z1[0] * z1[0] + z1[1] * z1[1] + z1[2] * z1[2])
    sigma = (z1[0] / rho, z1[1] / rho, z1[2] / rho)
    drift = model.drift(s, prm)  # with zero input: exact for the unactuated velocities, the rest is tau's to add
    if current is None:
        z2, tau = _backstepping(c, s, z1, sigma, rho, tangent, curvature, drift, gamma_dot, v_d)
    else:
        ground, ground_drift = _over_ground(s, drift, current)
        z2, tau = _backstepping(c, ground, z1, sigma, rho, tangent, curvature, ground_drift, gamma_dot, v_d)
    zeta = gamma_dot - v_d
    along = sigma[0] * tangent[0] + sigma[1] * tangent[1] + sigma[2] * tangent[2]
    gamma_ddot = -c.gains.k_zeta * zeta + along + correction
    lyapunov = (rho - 1.0) + 0.5 * zeta * zeta + 0.5 * (z2[0] * z2[0] + z2[1] * z2[1] + z2[2] * z2[2])
    return Control(tau, gamma_ddot, error, z1, lyapunov, drift)


def _path_in_body(
    model: Model, path: Path, s: Sequence[float], gamma: float, delta: float
) -> tuple[Float3, Float3, Float3, Float3]:
    """error = p - p_d(gamma), z1 = R' error - delta, tangent = R' p_d^gamma, curvature = R' p_d^gammagamma."""
    p_d, p_g, p_gg = model.path_seen(path.evaluate_floats(gamma))
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
    return error, z1, tangent, curvature


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
    c: ControllerConstants, s: Sequence[float], z1: Float3, sigma: Float3, rho: float, tangent: Float3,
    curvature: Float3, drift: Accelerations, gamma_dot: float, v_d: float,
) -> tuple[Float3, Float3]:  # fmt: skip
    """(z2, saturated tau): the virtual control alpha, its derivative (v_d constant), and the inputs that give
    nu_c_dot = alpha_dot - Delta' sigma - k2 z2 given the drift (curvature: R' p_d^gammagamma)."""
    (z1x, z1y, z1z), (sx, sy, sz), (tx, ty, tz) = z1, sigma, tangent
    u, v, w, p, q, r = s[12:18]
    k1, inv_delta, delta = c.gains.k1, c.inverse_delta, c.gains.delta
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
    k2 = c.gains.k2
    z2u, z2q, z2r = u - alpha_u, q - alpha_q, r - alpha_r
    (m_u, j_q, j_r), (lim_u, lim_q, lim_r) = c.input_inertia, c.limits
    tau_u = m_u * (dalpha_u - sx - k2 * z2u - du)
    tau_q = j_q * (dalpha_q - delta * sz - k2 * z2q - dq)
    tau_r = j_r * (dalpha_r + delta * sy - k2 * z2r - dr)
    # Saturated: min(max(tau, -lim), lim) to the bit, NaN included, without six builtin calls per evaluation.
    return (z2u, z2q, z2r), (
        lim_u if tau_u > lim_u else -lim_u if tau_u < -lim_u else tau_u,
        lim_q if tau_q > lim_q else -lim_q if tau_q < -lim_q else tau_q,
        lim_r if tau_r > lim_r else -lim_r if tau_r < -lim_r else tau_r,
    )

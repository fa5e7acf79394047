"""Path-following controller for an underactuated AUV: the delta-shifted backstepping design.

After Aguiar & Hespanha (IEEE TAC 2007) as laid out in shared/reference/path-following.md. The error is measured
from a point delta = (delta, 0, 0) ahead of (delta < 0: behind) the vehicle, which the surge force and the pitch and
yaw torques can steer in every direction:

    z1 = R'(p - p_d(gamma)) - delta,   rho = sqrt(1 + |z1|^2),   sigma = z1 / rho
    alpha = Delta^-1 (-K1 sigma - nu_u + R' p_d^gamma v_d)            virtual (u, q, r)
    z2 = nu_c - alpha,    nu_c_dot := alpha_dot - Delta' sigma - K2 z2  (through the model's inverse)
    gamma_ddot = -k_zeta (gamma_dot - v_d) + sigma' R' p_d^gamma + v_tilde   (paper's eq. (3), as gamma_ddot)

V = (rho - 1) + zeta^2 / 2 + |z2|^2 / 2 has V_dot = -sigma' K1 sigma - k_zeta zeta^2 - z2' K2 z2 + zeta v_tilde,
so with no coordination input and no saturation V never increases, and the vehicle converges to the tube
|p - p_d| -> |delta| around its path. The same code serves the spatial and the planar model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehicles.dynamics import Model
from vehicles.geometry import FloatArray
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


@dataclass(frozen=True, slots=True)
class ControllerConstants:
    """What the controller uses at every evaluation and never changes for a vehicle: computed once."""

    delta_vec: FloatArray
    delta_mat: FloatArray
    delta_inv: FloatArray
    input_inertia: FloatArray
    limits: FloatArray
    no_input: FloatArray

    @staticmethod
    def of(model: Model, prm: VehicleParams, gains: PathFollowingGains) -> ControllerConstants:
        delta_vec = np.zeros(model.dim)
        delta_vec[0] = gains.delta
        return ControllerConstants(
            delta_vec, model.delta_matrix(gains.delta), model.delta_inverse(gains.delta),
            model.input_inertia(prm), model.input_limits(prm), np.zeros(model.dim),
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
    constants: ControllerConstants | None = None,
) -> PathFollowingOutput:
    """Inputs and gamma_ddot for state x on path at gamma, desired speed v_d (constant) plus correction.
    constants: ControllerConstants.of(model, prm, gains), passed in by callers that evaluate it often."""
    c = constants or ControllerConstants.of(model, prm, gains)
    s = model.unpack(x)
    dim = model.dim
    p_d, p_g, p_gg = path.evaluate(gamma)
    rot_t = s.rotation.T
    error = s.position - p_d[:dim]
    z1 = rot_t @ error - c.delta_vec
    rho = float(np.sqrt(1.0 + z1 @ z1))
    sigma = z1 / rho
    tangent = rot_t @ p_g[:dim]  # R' p_d^gamma
    w_hat = model.skew(s.angular_velocity)
    delta_mat, delta_inv = c.delta_mat, c.delta_inv
    nu_c, nu_u = model.split(s.velocity, s.angular_velocity)

    z1_dot = -w_hat @ z1 + delta_mat @ nu_c + nu_u - tangent * gamma_dot
    sigma_dot = (z1_dot - sigma * (sigma @ z1_dot)) / rho
    alpha = delta_inv @ (-gains.k1 * sigma - nu_u + tangent * v_d)

    # Accelerations with zero input: the unactuated ones are exact, the actuated ones are what the input must add to.
    v_dot0, w_dot0 = model.accelerations(s.rotation, s.velocity, s.angular_velocity, c.no_input, prm)
    nu_c_dot0, nu_u_dot = model.split(v_dot0, w_dot0)
    tangent_dot = -w_hat @ tangent + rot_t @ p_gg[:dim] * gamma_dot
    alpha_dot = delta_inv @ (-gains.k1 * sigma_dot - nu_u_dot + tangent_dot * v_d)

    z2 = nu_c - alpha
    nu_c_dot = alpha_dot - delta_mat.T @ sigma - gains.k2 * z2
    tau = np.clip(c.input_inertia * (nu_c_dot - nu_c_dot0), -c.limits, c.limits)

    zeta = gamma_dot - v_d
    gamma_ddot = -gains.k_zeta * zeta + float(sigma @ tangent) + correction
    lyapunov = (rho - 1.0) + 0.5 * zeta * zeta + 0.5 * float(z2 @ z2)
    return PathFollowingOutput(tau, gamma_ddot, error, z1, lyapunov, (v_dot0, w_dot0))

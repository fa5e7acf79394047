"""Underactuated AUV dynamics, eqs. (1)-(2) of the paper, as pure functions xdot = f(x, tau, params).

Spatial (6-DOF) state: x = [p (3), R (9, row-major), v (3), omega (3)]; inputs tau = (tau_u, tau_q, tau_r):
surge force and pitch / yaw torques (B1 = e1, B2 = [e2 e3]).

    p_dot = R v                                              (1a)
    R_dot = R S(omega)                                       (1b)
    M v_dot = -S(omega) M v + f_v + B1 u1                    (2a)
    J omega_dot = -S(v) M v - S(omega) J omega + f_w + B2 u2 (2b)

with f_v = -D_v(v) v - R'(0, 0, W - B) and f_w = -D_w(omega) omega + S(r_B) R'(0, 0, B). The inertial z axis
points up (the paper's helix climbs with gamma), so buoyancy is +B along z. The paper prints the moment with a minus
sign, which is the north-east-down convention; with z up, +S(r_B) R'(0,0,B) is the physical buoyancy moment and
makes a vehicle whose centre of buoyancy lies above its centre of mass stable in roll and pitch.

Planar (3-DOF) state: x = [p (2), R (4), v (2), r (1)], inputs tau = (tau_u, tau_r). This is the restriction of the
spatial model to the horizontal plane. The paper drops the first two terms of (2b) in the plane; we keep the one that
survives the restriction, the Munk moment (m_u - m_v) u v, because it is physical and the planar controller
cancels it anyway.

The closed loop is evaluated four times per step per vehicle on 3-vectors, where numpy's per-call cost dominates the
arithmetic, so the hot path is plain floats on the "lifted" state: 18 floats in the spatial layout, into which the
planar state embeds (z = 0, no heave, roll or pitch; it stays there because neither the planar forces nor the planar
inputs have an out-of-plane part). The models' array methods (derivative, accelerations, normalize, ...) go through
the same float functions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from comms.records.records import FloatArray
from vehicles.geometry import Float3, reorthonormalized
from vehicles.params import VehicleParams, has_lift

Accelerations = tuple[Float3, Float3]  # (v_dot, omega_dot), body frame
LIFTED_SIZE = 18  # p (3), R (9, row-major), v (3), omega (3): the spatial layout, for both models
PathVectors = tuple[Float3, Float3, Float3]  # (p_d, dp_d/dgamma, d2p_d/dgamma2)


@dataclass(frozen=True, slots=True)
class Unpacked:
    """Views of a state vector: position, attitude, body linear and angular velocity."""

    position: FloatArray
    rotation: FloatArray
    velocity: FloatArray
    angular_velocity: FloatArray


# --- the hot path: plain floats in the spatial layout -----------------------------------------------------------
# Both models are integrated as an 18-float spatial state ("lifted"): the planar state embeds with zero heave, roll
# and pitch and stays there, because its forces have no out-of-plane part. On 3-vectors numpy's per-call overhead
# costs more than the arithmetic, so this is written out in floats.


def kinematics(s: Sequence[float], acc: Accelerations) -> tuple[float, ...]:
    """xdot of a lifted state s given its accelerations: p_dot = R v (1a), R_dot = R S(omega) (1b)."""
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = s[3:12]
    u, v, w, p, q, r = s[12:18]
    return (
        r11 * u + r12 * v + r13 * w, r21 * u + r22 * v + r23 * w, r31 * u + r32 * v + r33 * w,
        r12 * r - r13 * q, r13 * p - r11 * r, r11 * q - r12 * p,
        r22 * r - r23 * q, r23 * p - r21 * r, r21 * q - r22 * p,
        r32 * r - r33 * q, r33 * p - r31 * r, r31 * q - r32 * p,
        *acc[0], *acc[1],
    )  # fmt: skip


def with_inputs(drift: Accelerations, tau: Float3, prm: VehicleParams) -> Accelerations:
    """Accelerations with inputs tau = (tau_u, tau_q, tau_r) from those with none: (2) is linear in the input
    (B1 = e1, B2 = [e2 e3] constant)."""
    (du, dv, dw), (dp, dq, dr) = drift
    return (du + tau[0] / prm.mass[0], dv, dw), (dp, dq + tau[1] / prm.inertia[1], dr + tau[2] / prm.inertia[2])


def spatial_drift(s: Sequence[float], prm: VehicleParams) -> Accelerations:
    """(v_dot, omega_dot) of eq. (2) with no input, for a lifted state."""
    m1, m2, m3 = prm.mass
    j1, j2, j3 = prm.inertia
    z0, z1, z2 = s[9:12]  # R' e3: inertial up, body axes
    u, sv, hw, p, q, r = s[12:18]
    a1, a2, a3 = m1 * u, m2 * sv, m3 * hw  # M v
    h1, h2, h3 = j1 * p, j2 * q, j3 * r  # J omega
    lin, quad, net = prm.linear_damping, prm.quadratic_damping, prm.weight - prm.buoyancy
    f1 = -(lin[0] + quad[0] * abs(u)) * u - net * z0 - (q * a3 - r * a2)
    f2 = -(lin[1] + quad[1] * abs(sv)) * sv - net * z1 - (r * a1 - p * a3)
    f3 = -(lin[2] + quad[2] * abs(hw)) * hw - net * z2 - (p * a2 - q * a1)
    alin, aquad, (b0, b1, b2), buoy = (
        prm.angular_linear_damping, prm.angular_quadratic_damping, prm.center_of_buoyancy, prm.buoyancy,
    )  # fmt: skip
    g1 = -(alin[0] + aquad[0] * abs(p)) * p + buoy * (b1 * z2 - b2 * z1)
    g2 = -(alin[1] + aquad[1] * abs(q)) * q + buoy * (b2 * z0 - b0 * z2)
    g3 = -(alin[2] + aquad[2] * abs(r)) * r + buoy * (b0 * z1 - b1 * z0)
    g1 -= (sv * a3 - hw * a2) + (q * h3 - r * h2)
    g2 -= (hw * a1 - u * a3) + (r * h1 - p * h3)
    g3 -= (u * a2 - sv * a1) + (p * h2 - q * h1)
    if has_lift(prm):
        y, z, m, n = lift_terms(u, sv, hw, q, r, prm)
        f2, f3, g2, g3 = f2 + y, f3 + z, g2 + m, g3 + n
    return (f1 / m1, f2 / m2, f3 / m3), (g1 / j1, g2 / j2, g3 / j3)


def lift_terms(
    u: float, v: float, w: float, q: float, r: float, prm: VehicleParams
) -> tuple[float, float, float, float]:
    """Sway and heave forces, pitch and yaw moments of the hull's and fins' lift (Y, Z, M, N) [N, N m].

    Prestero (MIT/WHOI MS thesis, 2001, sec. 3.6-3.7): the hull and the fins at x_f meet the flow at the angle of
    attack v/u (w/u), plus r x_f / u (-q x_f / u) at the fins, and lift against it, Y = Y_uv u v + Y_ur u r. For an
    axisymmetric hull the vertical plane mirrors it in this frame (z up, y to port): Z = Z_uw u w + Z_uq u q with
    Z_uw = Y_uv, Z_uq = -Y_ur, and M = M_uw u w + M_uq u q with M_uw = -N_uv, M_uq = N_ur (a fin at x_f < 0 gives
    N_uv = -c x_f > 0, which turns the nose into the flow: weathercock stability; N_ur = M_uq = -c x_f^2 < 0
    damps the rates). All four vanish at rest, as lift does."""
    y_uv, y_ur, n_uv, n_ur = prm.lift_uv, prm.lift_ur, prm.lift_moment_uv, prm.lift_moment_ur
    return (
        u * (y_uv * v + y_ur * r),
        u * (y_uv * w - y_ur * q),
        u * (n_ur * q - n_uv * w),
        u * (n_uv * v + n_ur * r),
    )


def planar_drift(s: Sequence[float], prm: VehicleParams) -> Accelerations:
    """The planar model's (v_dot, omega_dot) with no input, embedded in 3-D; no restoring terms act in the plane."""
    m_u, m_v = prm.mass[0], prm.mass[1]
    u, sway, r = s[12], s[13], s[17]
    lin, quad = prm.linear_damping, prm.quadratic_damping
    u_dot = (m_v * sway * r - (lin[0] + quad[0] * abs(u)) * u) / m_u
    v_dot = (-m_u * u * r - (lin[1] + quad[1] * abs(sway)) * sway) / m_v
    damping_r = prm.angular_linear_damping[2] + prm.angular_quadratic_damping[2] * abs(r)
    r_dot = ((m_u - m_v) * u * sway - damping_r * r) / prm.inertia[2]
    if has_lift(prm):
        y, _, _, n = lift_terms(u, sway, 0.0, 0.0, r, prm)
        v_dot, r_dot = v_dot + y / m_v, r_dot + n / prm.inertia[2]
    return (u_dot, v_dot, 0.0), (0.0, 0.0, r_dot)


def reorthonormalize(s: Sequence[float]) -> list[float]:
    """A lifted state with its attitude projected back onto SO(3) after an integration step."""
    return [*s[0:3], *reorthonormalized(s[3:12]), *s[12:LIFTED_SIZE]]


# --- the models: array interface for setup, telemetry and tests, and what the hot path needs of each -------------


class SpatialModel:
    """The 6-DOF model of eqs. (1)-(2)."""

    dim = 3
    state_size = 18

    def unpack(self, x: FloatArray) -> Unpacked:
        return Unpacked(x[0:3], x[3:12].reshape(3, 3), x[12:15], x[15:18])

    def pack(self, p: FloatArray, rot: FloatArray, v: FloatArray, w: FloatArray) -> FloatArray:
        return np.concatenate((p, rot.reshape(9), v, w))

    def lift(self, x: FloatArray) -> list[float]:
        """The state as 18 floats in the spatial layout (already is)."""
        values: list[float] = x.tolist()
        return values

    def lower(self, s: Sequence[float]) -> FloatArray:
        """Inverse of lift; also maps a lifted xdot to this model's xdot."""
        return np.array(s, dtype=float)

    def drift(self, s: Sequence[float], prm: VehicleParams) -> Accelerations:
        return spatial_drift(s, prm)

    def path_seen(self, path: PathVectors) -> PathVectors:
        """The path's (p_d, dp_d/dgamma, d2p_d/dgamma2) as the vehicle follows them: all of them."""
        return path

    def vector(self, v: Sequence[float]) -> FloatArray:
        """A body or inertial 3-vector in this model's dimensions."""
        return np.array(v, dtype=float)

    def angular(self, w: Sequence[float]) -> FloatArray:
        """An angular 3-vector (rate or acceleration) in this model's dimensions."""
        return np.array(w, dtype=float)

    def inputs(self, tau: Float3) -> FloatArray:
        """This model's inputs from (tau_u, tau_q, tau_r)."""
        return np.array(tau, dtype=float)

    def lift_inputs(self, tau: FloatArray) -> Float3:
        return float(tau[0]), float(tau[1]), float(tau[2])

    def accelerations(
        self, rot: FloatArray, v: FloatArray, w: FloatArray, tau: FloatArray, prm: VehicleParams
    ) -> tuple[FloatArray, FloatArray]:
        """(v_dot, omega_dot) of eq. (2) for inputs tau = (tau_u, tau_q, tau_r)."""
        return _accelerations(self, rot, v, w, tau, prm)

    def derivative(self, x: FloatArray, tau: FloatArray, prm: VehicleParams) -> FloatArray:
        return _derivative(self, x, tau, prm)

    def spatial(self, x: FloatArray) -> Unpacked:
        """The state as 3-D quantities (for telemetry and plots)."""
        return self.unpack(x)

    def normalize(self, x: FloatArray) -> FloatArray:
        """Project the attitude back onto SO(3) after an integration step."""
        return self.lower(reorthonormalize(self.lift(x)))


class PlanarModel:
    """The 3-DOF horizontal-plane model: surge, sway, yaw; inputs (tau_u, tau_r)."""

    dim = 2
    state_size = 9
    # Where the planar state's entries sit in the lifted (spatial) one: p_xy, the 2x2 block of R, v_xy, r.
    _IN_LIFTED = (0, 1, 3, 4, 6, 7, 12, 13, 17)

    def unpack(self, x: FloatArray) -> Unpacked:
        return Unpacked(x[0:2], x[2:6].reshape(2, 2), x[6:8], x[8:9])

    def pack(self, p: FloatArray, rot: FloatArray, v: FloatArray, w: FloatArray) -> FloatArray:
        return np.concatenate((p, rot.reshape(4), v, w))

    def lift(self, x: FloatArray) -> list[float]:
        """The state embedded in the spatial layout: z = 0, yaw about the vertical axis, no heave, roll or pitch."""
        px, py, c11, c12, c21, c22, u, v, r = x.tolist()
        return [px, py, 0.0, c11, c12, 0.0, c21, c22, 0.0, 0.0, 0.0, 1.0, u, v, 0.0, 0.0, 0.0, r]

    def lower(self, s: Sequence[float]) -> FloatArray:
        """Inverse of lift; also maps a lifted xdot to this model's xdot."""
        return np.array([s[i] for i in self._IN_LIFTED], dtype=float)

    def drift(self, s: Sequence[float], prm: VehicleParams) -> Accelerations:
        return planar_drift(s, prm)

    def path_seen(self, path: PathVectors) -> PathVectors:
        """The path's (p_d, dp_d/dgamma, d2p_d/dgamma2) as the vehicle follows them: their horizontal projection."""
        p, dp, d2p = path
        return (p[0], p[1], 0.0), (dp[0], dp[1], 0.0), (d2p[0], d2p[1], 0.0)

    def vector(self, v: Sequence[float]) -> FloatArray:
        return np.array(v[:2], dtype=float)

    def angular(self, w: Sequence[float]) -> FloatArray:
        return np.array(w[2:], dtype=float)

    def inputs(self, tau: Float3) -> FloatArray:
        return np.array((tau[0], tau[2]), dtype=float)

    def lift_inputs(self, tau: FloatArray) -> Float3:
        return float(tau[0]), 0.0, float(tau[1])

    def accelerations(
        self, rot: FloatArray, v: FloatArray, w: FloatArray, tau: FloatArray, prm: VehicleParams
    ) -> tuple[FloatArray, FloatArray]:
        """(v_dot, r_dot) for inputs tau = (tau_u, tau_r)."""
        return _accelerations(self, rot, v, w, tau, prm)

    def derivative(self, x: FloatArray, tau: FloatArray, prm: VehicleParams) -> FloatArray:
        return _derivative(self, x, tau, prm)

    def spatial(self, x: FloatArray) -> Unpacked:
        """The planar state embedded in 3-D: z = 0, yaw about the vertical axis."""
        return SPATIAL.unpack(np.array(self.lift(x)))

    def normalize(self, x: FloatArray) -> FloatArray:
        return self.lower(reorthonormalize(self.lift(x)))


Model = SpatialModel | PlanarModel
SPATIAL = SpatialModel()
PLANAR = PlanarModel()


# --- the array interface, the same for both models ----------------------------------------------------------------


def _derivative(model: Model, x: FloatArray, tau: FloatArray, prm: VehicleParams) -> FloatArray:
    s = model.lift(x)
    return model.lower(kinematics(s, with_inputs(model.drift(s, prm), model.lift_inputs(tau), prm)))


def _accelerations(
    model: Model, rot: FloatArray, v: FloatArray, w: FloatArray, tau: FloatArray, prm: VehicleParams
) -> tuple[FloatArray, FloatArray]:
    s = model.lift(model.pack(np.zeros(model.dim), rot, v, w))
    v_dot, w_dot = with_inputs(model.drift(s, prm), model.lift_inputs(tau), prm)
    return model.vector(v_dot), model.angular(w_dot)

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehicles.geometry import FloatArray, orthonormalize, skew, skew2
from vehicles.params import VehicleParams


@dataclass(frozen=True, slots=True)
class Unpacked:
    """Views of a state vector: position, attitude, body linear and angular velocity."""

    position: FloatArray
    rotation: FloatArray
    velocity: FloatArray
    angular_velocity: FloatArray


class SpatialModel:
    """The 6-DOF model of eqs. (1)-(2)."""

    dim = 3
    state_size = 18

    def unpack(self, x: FloatArray) -> Unpacked:
        return Unpacked(x[0:3], x[3:12].reshape(3, 3), x[12:15], x[15:18])

    def pack(self, p: FloatArray, rot: FloatArray, v: FloatArray, w: FloatArray) -> FloatArray:
        return np.concatenate((p, rot.reshape(9), v, w))

    def skew(self, w: FloatArray) -> FloatArray:
        return skew(w)

    def accelerations(
        self, rot: FloatArray, v: FloatArray, w: FloatArray, tau: FloatArray, prm: VehicleParams
    ) -> tuple[FloatArray, FloatArray]:
        """(v_dot, omega_dot) of eq. (2) for inputs tau = (tau_u, tau_q, tau_r).

        Written out in floats: on 3-vectors numpy's per-call overhead costs more than the arithmetic."""
        m1, m2, m3 = prm.mass
        j1, j2, j3 = prm.inertia
        u, sv, hw = float(v[0]), float(v[1]), float(v[2])
        p, q, r = float(w[0]), float(w[1]), float(w[2])
        z0, z1, z2 = float(rot[2, 0]), float(rot[2, 1]), float(rot[2, 2])  # R' e3: inertial up, body axes
        a1, a2, a3 = m1 * u, m2 * sv, m3 * hw  # M v
        h1, h2, h3 = j1 * p, j2 * q, j3 * r  # J omega
        lin, quad, net = prm.linear_damping, prm.quadratic_damping, prm.weight - prm.buoyancy
        f1 = -(lin[0] + quad[0] * abs(u)) * u - net * z0 - (q * a3 - r * a2) + float(tau[0])
        f2 = -(lin[1] + quad[1] * abs(sv)) * sv - net * z1 - (r * a1 - p * a3)
        f3 = -(lin[2] + quad[2] * abs(hw)) * hw - net * z2 - (p * a2 - q * a1)
        alin, aquad, (b0, b1, b2), buoy = (
            prm.angular_linear_damping, prm.angular_quadratic_damping, prm.center_of_buoyancy, prm.buoyancy,
        )  # fmt: skip
        g1 = -(alin[0] + aquad[0] * abs(p)) * p + buoy * (b1 * z2 - b2 * z1)
        g2 = -(alin[1] + aquad[1] * abs(q)) * q + buoy * (b2 * z0 - b0 * z2)
        g3 = -(alin[2] + aquad[2] * abs(r)) * r + buoy * (b0 * z1 - b1 * z0)
        g1 -= (sv * a3 - hw * a2) + (q * h3 - r * h2)
        g2 -= (hw * a1 - u * a3) + (r * h1 - p * h3) - float(tau[1])
        g3 -= (u * a2 - sv * a1) + (p * h2 - q * h1) - float(tau[2])
        return np.array([f1 / m1, f2 / m2, f3 / m3]), np.array([g1 / j1, g2 / j2, g3 / j3])

    def with_input(
        self, v_dot0: FloatArray, w_dot0: FloatArray, tau: FloatArray, prm: VehicleParams
    ) -> tuple[FloatArray, FloatArray]:
        """Accelerations with inputs tau from those with none: (2) is linear in the input (B1, B2 constant)."""
        return (
            v_dot0 + np.array([float(tau[0]) / prm.mass[0], 0.0, 0.0]),
            w_dot0 + np.array([0.0, float(tau[1]) / prm.inertia[1], float(tau[2]) / prm.inertia[2]]),
        )

    def derivative(self, x: FloatArray, tau: FloatArray, prm: VehicleParams) -> FloatArray:
        s = self.unpack(x)
        return self.derivative_from(x, *self.accelerations(s.rotation, s.velocity, s.angular_velocity, tau, prm))

    def derivative_from(self, x: FloatArray, v_dot: FloatArray, w_dot: FloatArray) -> FloatArray:
        """xdot given the accelerations (the controller has most of them already)."""
        s = self.unpack(x)
        r_dot = s.rotation @ skew(s.angular_velocity)
        return np.concatenate((s.rotation @ s.velocity, r_dot.reshape(9), v_dot, w_dot))

    def spatial(self, x: FloatArray) -> Unpacked:
        """The state as 3-D quantities (for telemetry and plots)."""
        return self.unpack(x)

    def normalize(self, x: FloatArray) -> FloatArray:
        """Project the attitude back onto SO(3) after an integration step."""
        out = x.copy()
        out[3:12] = orthonormalize(x[3:12].reshape(3, 3)).reshape(9)
        return out

    # --- what the delta-shifted path-following controller needs to know of the model ---

    def split(self, v: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Actuated velocities (u, q, r) and the unactuated part (0, v, w) of v + S(delta) omega."""
        return np.array([v[0], w[1], w[2]]), np.array([0.0, v[1], v[2]])

    def delta_matrix(self, delta: float) -> FloatArray:
        """Delta with v + S(delta) omega = Delta (u, q, r) + (0, v, w), for delta = (delta, 0, 0)."""
        return np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -delta], [0.0, delta, 0.0]])

    def delta_inverse(self, delta: float) -> FloatArray:
        """Delta^-1 in closed form (a general solver costs more than the rest of the controller)."""
        return np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0 / delta], [0.0, -1.0 / delta, 0.0]])

    def input_inertia(self, prm: VehicleParams) -> FloatArray:
        """How hard each input pushes its own actuated velocity: (m_u, J_q, J_r)."""
        return np.array([prm.mass[0], prm.inertia[1], prm.inertia[2]])

    def input_limits(self, prm: VehicleParams) -> FloatArray:
        return np.array([prm.max_surge_force, prm.max_torque, prm.max_torque])


class PlanarModel:
    """The 3-DOF horizontal-plane model: surge, sway, yaw; inputs (tau_u, tau_r)."""

    dim = 2
    state_size = 9

    def unpack(self, x: FloatArray) -> Unpacked:
        return Unpacked(x[0:2], x[2:6].reshape(2, 2), x[6:8], x[8:9])

    def pack(self, p: FloatArray, rot: FloatArray, v: FloatArray, w: FloatArray) -> FloatArray:
        return np.concatenate((p, rot.reshape(4), v, w))

    def skew(self, w: FloatArray) -> FloatArray:
        return skew2(float(w[0]))

    def accelerations(
        self, rot: FloatArray, v: FloatArray, w: FloatArray, tau: FloatArray, prm: VehicleParams
    ) -> tuple[FloatArray, FloatArray]:
        """(v_dot, r_dot) for inputs tau = (tau_u, tau_r); no restoring terms act in the plane."""
        m_u, m_v = prm.mass[0], prm.mass[1]
        u, sway, r = float(v[0]), float(v[1]), float(w[0])
        lin, quad = prm.linear_damping, prm.quadratic_damping
        u_dot = (m_v * sway * r - (lin[0] + quad[0] * abs(u)) * u + tau[0]) / m_u
        v_dot = (-m_u * u * r - (lin[1] + quad[1] * abs(sway)) * sway) / m_v
        damping_r = prm.angular_linear_damping[2] + prm.angular_quadratic_damping[2] * abs(r)
        r_dot = ((m_u - m_v) * u * sway - damping_r * r + tau[1]) / prm.inertia[2]
        return np.array([u_dot, v_dot]), np.array([r_dot])

    def derivative(self, x: FloatArray, tau: FloatArray, prm: VehicleParams) -> FloatArray:
        s = self.unpack(x)
        return self.derivative_from(x, *self.accelerations(s.rotation, s.velocity, s.angular_velocity, tau, prm))

    def derivative_from(self, x: FloatArray, v_dot: FloatArray, w_dot: FloatArray) -> FloatArray:
        s = self.unpack(x)
        r_dot = s.rotation @ skew2(float(s.angular_velocity[0]))
        return np.concatenate((s.rotation @ s.velocity, r_dot.reshape(4), v_dot, w_dot))

    def with_input(
        self, v_dot0: FloatArray, w_dot0: FloatArray, tau: FloatArray, prm: VehicleParams
    ) -> tuple[FloatArray, FloatArray]:
        return v_dot0 + np.array([float(tau[0]) / prm.mass[0], 0.0]), w_dot0 + float(tau[1]) / prm.inertia[2]

    def spatial(self, x: FloatArray) -> Unpacked:
        """The planar state embedded in 3-D: z = 0, yaw about the vertical axis."""
        s = self.unpack(x)
        rot = np.eye(3)
        rot[:2, :2] = s.rotation
        return Unpacked(
            np.append(s.position, 0.0),
            rot,
            np.append(s.velocity, 0.0),
            np.array([0.0, 0.0, s.angular_velocity[0]]),
        )

    def normalize(self, x: FloatArray) -> FloatArray:
        out = x.copy()
        out[2:6] = orthonormalize(x[2:6].reshape(2, 2)).reshape(4)
        return out

    def split(self, v: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
        return np.array([v[0], w[0]]), np.array([0.0, v[1]])

    def delta_matrix(self, delta: float) -> FloatArray:
        return np.array([[1.0, 0.0], [0.0, -delta]])

    def delta_inverse(self, delta: float) -> FloatArray:
        return np.array([[1.0, 0.0], [0.0, -1.0 / delta]])

    def input_inertia(self, prm: VehicleParams) -> FloatArray:
        return np.array([prm.mass[0], prm.inertia[2]])

    def input_limits(self, prm: VehicleParams) -> FloatArray:
        return np.array([prm.max_surge_force, prm.max_torque])


Model = SpatialModel | PlanarModel
SPATIAL = SpatialModel()
PLANAR = PlanarModel()

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

from vehicles.geometry import FloatArray, cross, orthonormalize, skew, skew2
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
    input_size = 3

    def unpack(self, x: FloatArray) -> Unpacked:
        return Unpacked(x[0:3], x[3:12].reshape(3, 3), x[12:15], x[15:18])

    def pack(self, p: FloatArray, rot: FloatArray, v: FloatArray, w: FloatArray) -> FloatArray:
        return np.concatenate((p, rot.reshape(9), v, w))

    def skew(self, w: FloatArray) -> FloatArray:
        return skew(w)

    def accelerations(
        self, rot: FloatArray, v: FloatArray, w: FloatArray, tau: FloatArray, prm: VehicleParams
    ) -> tuple[FloatArray, FloatArray]:
        """(v_dot, omega_dot) of eq. (2) for inputs tau = (tau_u, tau_q, tau_r)."""
        mass = np.asarray(prm.mass)
        inertia = np.asarray(prm.inertia)
        mv = mass * v
        vertical = rot[2]  # R' e3: the inertial up axis in body coordinates
        f_v = -(np.asarray(prm.linear_damping) + np.asarray(prm.quadratic_damping) * np.abs(v)) * v
        f_v = f_v - (prm.weight - prm.buoyancy) * vertical
        f_w = -(np.asarray(prm.angular_linear_damping) + np.asarray(prm.angular_quadratic_damping) * np.abs(w)) * w
        f_w = f_w + prm.buoyancy * cross(np.asarray(prm.center_of_buoyancy), vertical)
        force = f_v - cross(w, mv)
        force[0] += tau[0]
        moment = f_w - cross(v, mv) - cross(w, inertia * w)
        moment[1] += tau[1]
        moment[2] += tau[2]
        return force / mass, moment / inertia

    def derivative(self, x: FloatArray, tau: FloatArray, prm: VehicleParams) -> FloatArray:
        s = self.unpack(x)
        v_dot, w_dot = self.accelerations(s.rotation, s.velocity, s.angular_velocity, tau, prm)
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
    input_size = 2

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
        v_dot, w_dot = self.accelerations(s.rotation, s.velocity, s.angular_velocity, tau, prm)
        r_dot = s.rotation @ skew2(float(s.angular_velocity[0]))
        return np.concatenate((s.rotation @ s.velocity, r_dot.reshape(4), v_dot, w_dot))

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

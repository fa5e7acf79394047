"""The float controller and the float RK4 step against straightforward numpy transcriptions (the test oracles).

vehicles.path_following writes the law once, in 3-D floats, for both models; these references write it the obvious
way instead, with each model's own matrices (Delta, S(omega), the actuated / unactuated split) and a general solver
for Delta^-1, so a slip in the float arithmetic or in the planar embedding shows up here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from comms.records.records import FloatArray
from vehicles.agent import VehicleConfig, VehicleState, step
from vehicles.coordination import CoordinationGains
from vehicles.dynamics import PLANAR, SPATIAL, Model
from vehicles.geometry import rotation_2d, rotation_from_rpy
from vehicles.params import PRESETS, VehicleParams
from vehicles.path_following import Backstepping, path_following
from vehicles.paths import Helix, Lawnmower, Path

REMUS = PRESETS["remus100"]
GAINS = Backstepping(delta=-1.0, k1=0.5, k2=1.0, k_zeta=1.0)
# A climbing helix for both models: the planar vehicle must follow its horizontal projection.
HELIX = Helix(radius=20.0, climb=0.05, period=400.0, phase=-3 * math.pi / 4, center=(1.0, -2.0, -7.0))
SURVEY = Lawnmower(origin=(0.0, 0.0, -4.0), leg_length=40.0, spacing=10.0, legs=3, heading=0.4)


@dataclass(frozen=True)
class Reference:
    tau: FloatArray
    gamma_ddot: float
    error: FloatArray
    z1: FloatArray
    lyapunov: float


def skew_of(model: Model, w: FloatArray) -> FloatArray:
    if model.dim == 3:
        return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return np.array([[0.0, -w[0]], [w[0], 0.0]])


def delta_matrix(model: Model, delta: float) -> FloatArray:
    """Delta with v + S(delta) omega = Delta nu_c + nu_u, for delta = (delta, 0, 0)."""
    if model.dim == 3:
        return np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -delta], [0.0, delta, 0.0]])
    return np.array([[1.0, 0.0], [0.0, -delta]])


def split(model: Model, v: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Actuated velocities nu_c, (u, q, r) or (u, r), and the unactuated rest nu_u."""
    if model.dim == 3:
        return np.array([v[0], w[1], w[2]]), np.array([0.0, v[1], v[2]])
    return np.array([v[0], w[0]]), np.array([0.0, v[1]])


def input_inertia_and_limits(model: Model, prm: VehicleParams) -> tuple[FloatArray, FloatArray]:
    if model.dim == 3:
        inertia = np.array([prm.mass[0], prm.inertia[1], prm.inertia[2]])
        return inertia, np.array([prm.max_surge_force, prm.max_torque, prm.max_torque])
    return np.array([prm.mass[0], prm.inertia[2]]), np.array([prm.max_surge_force, prm.max_torque])


def actuated_damping(model: Model, prm: VehicleParams) -> tuple[FloatArray, FloatArray]:
    """(linear, quadratic) damping of the actuated velocities nu_c."""
    if model.dim == 3:
        return (np.array([prm.linear_damping[0], prm.angular_linear_damping[1], prm.angular_linear_damping[2]]),
                np.array([prm.quadratic_damping[0], prm.angular_quadratic_damping[1],
                          prm.angular_quadratic_damping[2]]))  # fmt: skip
    return (np.array([prm.linear_damping[0], prm.angular_linear_damping[2]]),
            np.array([prm.quadratic_damping[0], prm.angular_quadratic_damping[2]]))  # fmt: skip


def reference_controller(
    model: Model, prm: VehicleParams, gains: Backstepping, path: Path, x: FloatArray,
    gamma: float, gamma_dot: float, v_d: float, correction: float,
) -> Reference:  # fmt: skip
    """The equations of vehicles.path_following's docstring, line by line, in numpy."""
    s = model.unpack(x)
    dim = model.dim
    p_d, p_g, p_gg = (vec[:dim] for vec in path.evaluate(gamma))
    rot_t = s.rotation.T
    delta_vec = np.zeros(dim)
    delta_vec[0] = gains.delta
    error = s.position - p_d
    z1 = rot_t @ error - delta_vec
    rho = np.sqrt(1.0 + z1 @ z1)
    sigma = z1 / rho
    tangent = rot_t @ p_g
    w_hat = skew_of(model, s.angular_velocity)
    delta_mat = delta_matrix(model, gains.delta)
    nu_c, nu_u = split(model, s.velocity, s.angular_velocity)

    z1_dot = -w_hat @ z1 + delta_mat @ nu_c + nu_u - tangent * gamma_dot
    sigma_dot = (z1_dot - sigma * (sigma @ z1_dot)) / rho
    alpha = np.linalg.solve(delta_mat, -gains.k1 * sigma - nu_u + tangent * v_d)
    v_dot0, w_dot0 = model.accelerations(s.rotation, s.velocity, s.angular_velocity, np.zeros(dim), prm)
    nu_c_dot0, nu_u_dot = split(model, v_dot0, w_dot0)
    tangent_dot = -w_hat @ tangent + rot_t @ p_gg * gamma_dot
    alpha_dot = np.linalg.solve(delta_mat, -gains.k1 * sigma_dot - nu_u_dot + tangent_dot * v_d)
    z2 = nu_c - alpha
    nu_c_dot = alpha_dot - delta_mat.T @ sigma - gains.k2 * z2
    inertia, limits = input_inertia_and_limits(model, prm)
    raw = inertia * (nu_c_dot - nu_c_dot0)
    if gains.damping == "feedforward":  # the damping of nu_c fed forward at alpha, not cancelled at nu_c
        linear, quadratic = actuated_damping(model, prm)
        raw = raw + (linear + quadratic * np.abs(alpha)) * alpha - (linear + quadratic * np.abs(nu_c)) * nu_c
    tau = np.clip(raw, -limits, limits)

    zeta = gamma_dot - v_d
    gamma_ddot = -gains.k_zeta * zeta + sigma @ tangent + correction
    lyapunov = (rho - 1.0) + 0.5 * zeta**2 + 0.5 * z2 @ z2
    return Reference(tau, float(gamma_ddot), error, z1, float(lyapunov))


def random_state(model: Model, path: Path, rng: np.random.Generator, gamma: float, calm: bool) -> FloatArray:
    """Somewhere near the path, any attitude, moving and turning (calm: slowly, so that some inputs stay within
    their limits whichever way the damping enters them)."""
    point, slope, _ = path.evaluate(gamma)
    near = point + rng.normal(0.0, 0.3 if calm else 3.0, 3)
    speed, spin, turn = (0.3, 0.03, 0.2) if calm else (1.0, 0.3, math.pi)
    yaw = math.atan2(slope[1], slope[0]) if calm else 0.0  # calm: heading roughly along the path
    if model.dim == 3:
        roll, pitch, spin_yaw = rng.uniform(-turn, turn, 3)
        rot = rotation_from_rpy(roll, pitch, yaw + spin_yaw)
        return SPATIAL.pack(near, rot, rng.normal(0.0, speed, 3), rng.normal(0.0, spin, 3))
    return PLANAR.pack(
        near[:2], rotation_2d(yaw + rng.uniform(-turn, turn)), rng.normal(0.0, speed, 2), rng.normal(0.0, spin, 1)
    )


CASES = [(SPATIAL, HELIX), (PLANAR, HELIX), (PLANAR, SURVEY)]
IDS = ["spatial-helix", "planar-helix", "planar-survey"]


@pytest.mark.parametrize("damping", ["feedforward", "cancel"])
@pytest.mark.parametrize(("model", "path"), CASES, ids=IDS)
def test_float_controller_matches_the_numpy_transcription(model, path, damping):
    gains = replace(GAINS, damping=damping)
    rng = np.random.default_rng(11)
    saturated = unsaturated = 0
    for i in range(400):
        gamma = rng.uniform(-20.0, 120.0)
        x = random_state(model, path, rng, gamma, calm=i % 2 == 0)
        gamma_dot, correction = rng.uniform(-0.5, 2.0), rng.normal(0.0, 0.2)
        got = path_following(model, REMUS, gains, path, x, gamma, gamma_dot, 1.0, correction)
        want = reference_controller(model, REMUS, gains, path, x, gamma, gamma_dot, 1.0, correction)
        assert got.tau.shape == want.tau.shape == (model.dim,)
        np.testing.assert_allclose(got.tau, want.tau, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(got.error, want.error, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got.z1, want.z1, rtol=1e-12, atol=1e-12)
        assert got.gamma_ddot == pytest.approx(want.gamma_ddot, rel=1e-12, abs=1e-12)
        assert got.lyapunov == pytest.approx(want.lyapunov, rel=1e-12, abs=1e-12)
        limits = input_inertia_and_limits(model, REMUS)[1]
        at_limit = np.abs(want.tau) == limits
        saturated += int(at_limit.any())
        unsaturated += int(not at_limit.any())
    assert saturated > 20 and unsaturated > 20  # both regimes of the clip were exercised


def reference_step(cfg: VehicleConfig, x: FloatArray, gamma: float, gamma_dot: float, dt: float):
    """Classical RK4 of [model.derivative(x, tau), gamma_dot, gamma_ddot] with no neighbours, in numpy."""
    n, v_r = cfg.model.state_size, cfg.coordination.v_r

    def closed_loop(z: FloatArray) -> FloatArray:
        g_dot = float(z[n + 1])
        v_tilde = -cfg.coordination.k2 * (g_dot - v_r)  # law (5), corrected, with no neighbours
        out = path_following(cfg.model, cfg.params, GAINS, cfg.path, z[:n], z[n], g_dot, v_r, v_tilde)
        return np.concatenate((cfg.model.derivative(z[:n], out.tau, cfg.params), [g_dot, out.gamma_ddot]))

    z = np.concatenate((x, [gamma, gamma_dot]))
    k1 = closed_loop(z)
    k2 = closed_loop(z + dt / 2 * k1)
    k3 = closed_loop(z + dt / 2 * k2)
    k4 = closed_loop(z + dt * k3)
    z = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return cfg.model.normalize(z[:n]), float(z[n]), float(z[n + 1])


@pytest.mark.parametrize(("model", "path"), CASES, ids=IDS)
def test_float_step_is_rk4_of_the_closed_loop(model, path):
    cfg = VehicleConfig(1, model, REMUS, path, GAINS, CoordinationGains(v_r=1.0))
    rng = np.random.default_rng(5)
    for _ in range(50):
        gamma = rng.uniform(-20.0, 120.0)
        x, gamma_dot = random_state(model, path, rng, gamma, calm=False), rng.uniform(-0.5, 2.0)
        state, telemetry = step(cfg, VehicleState(3.0, x, gamma, gamma_dot), 0.1, neighbours=[])
        want_x, want_gamma, want_gamma_dot = reference_step(cfg, x, gamma, gamma_dot, 0.1)
        assert state.x.shape == x.shape and state.t == pytest.approx(3.1)
        np.testing.assert_allclose(state.x, want_x, rtol=1e-11, atol=1e-11)
        assert state.gamma == pytest.approx(want_gamma, rel=1e-12)
        assert state.gamma_dot == pytest.approx(want_gamma_dot, rel=1e-11, abs=1e-11)
        assert telemetry.x is x and telemetry.error.shape == telemetry.tau.shape == (model.dim,)

"""Open-loop behaviour of the vehicle models: coasting, steady speed, roll stability, staying on SO(3)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from comms.records.records import FloatArray
from vehicles.dynamics import PLANAR, SPATIAL, Model
from vehicles.geometry import orthonormalize, reorthonormalized, roll_pitch_yaw, rotation_2d, rotation_from_rpy
from vehicles.params import PRESETS, VehicleParams, without_lift

REMUS = without_lift(PRESETS["remus100"])  # eq. (2) as the paper has it (the lift: tests/test_lift.py)
NEUTRAL = replace(REMUS, buoyancy=REMUS.weight)


def simulate(model: Model, prm: VehicleParams, x: FloatArray, tau: FloatArray, seconds: float, dt: float = 0.05):
    """Fixed-step RK4 of the open-loop model, attitude re-projected each step."""
    for _ in range(round(seconds / dt)):
        k1 = model.derivative(x, tau, prm)
        k2 = model.derivative(x + dt / 2 * k1, tau, prm)
        k3 = model.derivative(x + dt / 2 * k2, tau, prm)
        k4 = model.derivative(x + dt * k3, tau, prm)
        x = model.normalize(x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
    return x


def spatial_state(rpy=(0.0, 0.0, 0.0), v=(0.0, 0.0, 0.0), w=(0.0, 0.0, 0.0)) -> FloatArray:
    return SPATIAL.pack(np.zeros(3), rotation_from_rpy(*rpy), np.array(v, float), np.array(w, float))


def steady_surge(prm: VehicleParams, thrust: float) -> float:
    """Solve lin u + quad u^2 = thrust for u > 0."""
    lin, quad = prm.linear_damping[0], prm.quadratic_damping[0]
    return (-lin + math.sqrt(lin * lin + 4 * quad * thrust)) / (2 * quad)


def test_coasts_to_rest_when_neutrally_buoyant():
    x = simulate(SPATIAL, NEUTRAL, spatial_state(v=(1.5, 0.2, -0.1), w=(0.1, 0.05, 0.2)), np.zeros(3), 300.0)
    s = SPATIAL.unpack(x)
    assert np.linalg.norm(s.velocity) < 2e-2
    assert np.linalg.norm(s.angular_velocity) < 1e-3


def test_buoyant_vehicle_rises_at_terminal_speed_and_stops_moving_horizontally():
    x = simulate(SPATIAL, REMUS, spatial_state(v=(1.0, 0.0, 0.0)), np.zeros(3), 400.0)
    s = SPATIAL.unpack(x)
    world_velocity = s.rotation @ s.velocity
    assert world_velocity[2] > 0.05  # W - B = -3.3 N pushes it up
    assert np.linalg.norm(world_velocity[:2]) < 0.05


@pytest.mark.parametrize("thrust", [5.0, 20.0, 50.0])
def test_steady_surge_speed_under_constant_thrust(thrust):
    x = simulate(SPATIAL, NEUTRAL, spatial_state(), np.array([thrust, 0.0, 0.0]), 200.0)
    s = SPATIAL.unpack(x)
    np.testing.assert_allclose(s.velocity[0], steady_surge(NEUTRAL, thrust), rtol=1e-4)
    np.testing.assert_allclose(s.velocity[1:], 0.0, atol=1e-9)


def test_roll_is_statically_stable():
    x = simulate(SPATIAL, NEUTRAL, spatial_state(rpy=(math.radians(30), 0.0, 0.0)), np.zeros(3), 60.0)
    roll, pitch, _ = roll_pitch_yaw(SPATIAL.unpack(x).rotation)
    assert abs(roll) < math.radians(0.5)
    assert abs(pitch) < math.radians(0.5)


def test_roll_would_be_unstable_with_buoyancy_below_the_centre_of_mass():
    """The sign check of the restoring moment: flip r_B and a small roll must grow."""
    upside_down = replace(NEUTRAL, center_of_buoyancy=(0.0, 0.0, -0.0196))
    x = simulate(SPATIAL, upside_down, spatial_state(rpy=(math.radians(2), 0.0, 0.0)), np.zeros(3), 20.0)
    roll, _, _ = roll_pitch_yaw(SPATIAL.unpack(x).rotation)
    assert abs(roll) > math.radians(20)


def test_attitude_stays_a_rotation_under_fast_turning():
    x = simulate(SPATIAL, REMUS, spatial_state(v=(1.0, 0, 0)), np.array([20.0, 5.0, -8.0]), 100.0)
    rot = SPATIAL.unpack(x).rotation
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) == pytest.approx(1.0, abs=1e-12)


def test_kinematics_move_the_vehicle_along_its_heading():
    x = spatial_state(rpy=(0.0, 0.0, math.pi / 2), v=(1.0, 0.0, 0.0))
    xdot = SPATIAL.derivative(x, np.zeros(3), NEUTRAL)
    np.testing.assert_allclose(xdot[:3], [0.0, 1.0, 0.0], atol=1e-12)


def test_planar_model_coasts_and_reaches_the_same_steady_speed():
    x0 = PLANAR.pack(np.zeros(2), rotation_2d(0.3), np.array([1.0, 0.3]), np.array([0.2]))
    coast = PLANAR.unpack(simulate(PLANAR, REMUS, x0, np.zeros(2), 300.0))
    assert np.linalg.norm(coast.velocity) < 2e-2 and abs(coast.angular_velocity[0]) < 1e-3
    # From a straight start: with sway, the Munk moment of a finless hull would settle into a steady turn.
    straight = PLANAR.pack(np.zeros(2), rotation_2d(0.3), np.array([1.0, 0.0]), np.array([0.0]))
    thrust = simulate(PLANAR, REMUS, straight, np.array([20.0, 0.0]), 300.0)
    np.testing.assert_allclose(PLANAR.unpack(thrust).velocity[0], steady_surge(REMUS, 20.0), rtol=1e-4)


def test_planar_model_is_the_spatial_model_restricted_to_the_plane():
    """With no roll, pitch or heave, the spatial accelerations reduce to the planar ones."""
    v, w = np.array([1.2, 0.3, 0.0]), np.array([0.0, 0.0, 0.15])
    tau3, tau2 = np.array([10.0, 0.0, 2.0]), np.array([10.0, 2.0])
    v3, w3 = SPATIAL.accelerations(np.eye(3), v, w, tau3, NEUTRAL)
    v2, w2 = PLANAR.accelerations(np.eye(2), v[:2], w[2:], tau2, NEUTRAL)
    np.testing.assert_allclose(v3[:2], v2, rtol=1e-12)
    np.testing.assert_allclose(w3[2], w2[0], rtol=1e-12)


@pytest.mark.parametrize("drift", [0.0, 1e-13, 1e-10, 1e-7, 1e-4, 1e-2, 0.3])
def test_reorthonormalized_is_the_svd_polar_projection(drift):
    """The float Newton-Schulz projection of each step agrees with the SVD one to its own round-off."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        drifted = rotation_from_rpy(*rng.uniform(-3.0, 3.0, 3)) + drift * rng.normal(size=(3, 3))
        got = np.array(reorthonormalized(drifted.reshape(9).tolist())).reshape(3, 3)
        np.testing.assert_allclose(got, orthonormalize(drifted), rtol=0, atol=1e-14)
        np.testing.assert_allclose(got @ got.T, np.eye(3), rtol=0, atol=4e-15)  # the SVD itself: ~2e-15


def test_reorthonormalized_keeps_the_reflection_guard():
    reflected = np.diag([1.0, 1.0, -1.0]) + 1e-9
    got = np.array(reorthonormalized(reflected.reshape(9).tolist())).reshape(3, 3)
    np.testing.assert_array_equal(got, orthonormalize(reflected))
    assert np.linalg.det(got) == pytest.approx(1.0)


def eq2_reference(prm: VehicleParams, rot: FloatArray, v: FloatArray, w: FloatArray, tau: FloatArray):
    """Eq. (2) written with numpy vector operations, independently of the model's float arithmetic."""
    mass, inertia, up = np.asarray(prm.mass), np.asarray(prm.inertia), rot.T @ np.array([0.0, 0.0, 1.0])
    f_v = -(np.asarray(prm.linear_damping) + np.asarray(prm.quadratic_damping) * np.abs(v)) * v
    f_v -= (prm.weight - prm.buoyancy) * up
    f_w = -(np.asarray(prm.angular_linear_damping) + np.asarray(prm.angular_quadratic_damping) * np.abs(w)) * w
    f_w += prm.buoyancy * np.cross(np.asarray(prm.center_of_buoyancy), up)
    force = f_v - np.cross(w, mass * v) + np.array([tau[0], 0.0, 0.0])
    moment = f_w - np.cross(v, mass * v) - np.cross(w, inertia * w) + np.array([0.0, tau[1], tau[2]])
    return force / mass, moment / inertia


def test_accelerations_follow_eq_2_and_are_linear_in_the_input():
    rng = np.random.default_rng(7)
    for _ in range(300):
        rot = rotation_from_rpy(*rng.uniform(-3.0, 3.0, 3))
        v, w, tau = rng.normal(0, 1, 3), rng.normal(0, 0.5, 3), rng.normal(0, 20, 3)
        expected = eq2_reference(REMUS, rot, v, w, tau)
        got = SPATIAL.accelerations(rot, v, w, tau, REMUS)  # the zero-input drift plus the input's part
        np.testing.assert_allclose(got[0], expected[0], atol=1e-12)
        np.testing.assert_allclose(got[1], expected[1], atol=1e-12)

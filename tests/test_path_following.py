"""The delta-shifted backstepping path-following controller on the full models."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import replace

import numpy as np
import pytest

from vehicles.agent import Telemetry, VehicleConfig, VehicleState, step
from vehicles.coordination import CoordinationGains
from vehicles.dynamics import PLANAR, SPATIAL
from vehicles.geometry import rotation_2d, rotation_from_rpy
from vehicles.nearest import closest_gamma
from vehicles.params import PRESETS
from vehicles.path_following import Backstepping
from vehicles.paths import Circle, Helix, Lawnmower, Line, Path

REMUS = PRESETS["remus100"]
PAPER_HELIX = Helix(radius=20.0, climb=0.05, period=400.0, phase=-3 * math.pi / 4)
GAINS = Backstepping(delta=-1.0, k1=0.5, k2=1.0, k_zeta=1.0)


def run_alone(path: Path, x0: np.ndarray, seconds: float, planar: bool = False, dt: float = 0.05, params=REMUS):
    """One vehicle, no neighbours (no coordination input), gamma0 at the nearest path point."""
    model = PLANAR if planar else SPATIAL
    cfg = VehicleConfig(1, model, params, path, GAINS, CoordinationGains(v_r=1.0))
    point = np.append(x0[:2], path.evaluate(0.0)[0][2]) if planar else x0[:3]
    state = VehicleState(0.0, x0, closest_gamma(path, point, -200.0, 200.0), 0.0)
    log: list[Telemetry] = []
    for _ in range(round(seconds / dt)):
        state, tel = step(cfg, state, dt, neighbours=[])
        log.append(tel)
    return log


def spatial_start(position, rpy_deg=(0.0, 0.0, 0.0)) -> np.ndarray:
    rot = rotation_from_rpy(*(math.radians(a) for a in rpy_deg))
    return SPATIAL.pack(np.array(position, float), rot, np.zeros(3), np.zeros(3))


def planar_start(position, yaw_deg) -> np.ndarray:
    return PLANAR.pack(np.array(position, float), rotation_2d(math.radians(yaw_deg)), np.zeros(2), np.zeros(1))


def shifted_error(log: list[Telemetry], delta: float = GAINS.delta) -> np.ndarray:
    """|z1| = |R'(p - p_d) - delta| = |(p - p_d) - R delta| over the log."""
    out = []
    for tel in log:
        dim = len(tel.error)
        rot = tel.x[3:12].reshape(3, 3) if dim == 3 else tel.x[2:6].reshape(2, 2)
        out.append(np.linalg.norm(tel.error - rot[:, 0] * delta))
    return np.array(out)


def test_lyapunov_function_never_increases_on_a_nominal_run():
    # A start 3 m off the helix, pointing along it: inputs stay inside their limits, so the design holds exactly.
    # (The REMUS's own thrust limit, set for its 2.5 m/s top speed, is reached in this start's first seconds: the
    # claim is the unsaturated design's, so the limit is raised to the 60 N the preset had before issue 16.)
    vehicle = dataclasses.replace(REMUS, max_surge_force=60.0)
    log = run_alone(PAPER_HELIX, spatial_start((-12.0, -16.0, 1.0), (0, 0, -45)), 120.0, dt=0.02, params=vehicle)
    tau = np.array([t.tau for t in log])
    assert np.all(np.abs(tau[:, 0]) < vehicle.max_surge_force) and np.all(np.abs(tau[:, 1:]) < vehicle.max_torque)
    v = np.array([t.lyapunov for t in log])
    assert v[0] > 0.5  # a real transient, not a start on the path
    assert np.max(np.diff(v)) <= 1e-6 * v[0]
    assert v[-1] < 1e-4


def test_lyapunov_function_never_increases_for_the_planar_model():
    log = run_alone(Circle(radius=30.0, period=200.0, phase=0.0), planar_start((25.0, -4.0), 60.0), 100.0, True, 0.02)
    v = np.array([t.lyapunov for t in log])
    assert np.max(np.diff(v)) <= 1e-6 * v[0]
    assert v[-1] < 1e-4


@pytest.mark.parametrize(
    ("position", "rpy"),
    [
        ((10.0, -15.0, -5.0), (0, 0, 0)),  # the paper's AUV 1 start
        ((0.0, 0.0, 0.0), (0, 0, 90)),  # at the helix axis
        ((30.0, 10.0, 8.0), (0, 0, 180)),  # outside, above, facing away
        ((-14.0, -14.0, -10.0), (10, -20, 45)),  # below the start of the path, rolled and pitched
    ],
)
def test_converges_into_the_tube_around_the_paper_helix(position, rpy):
    log = run_alone(PAPER_HELIX, spatial_start(position, rpy), 150.0)
    last = log[-round(30 / 0.05) :]  # the last 30 s
    z1 = shifted_error(last)
    errors = np.array([np.linalg.norm(t.error) for t in last])
    assert z1.max() < 0.05
    assert errors.max() < abs(GAINS.delta) + 0.05
    np.testing.assert_allclose([t.gamma_dot for t in last], 1.0, atol=0.02)


@pytest.mark.parametrize("yaw", [0.0, 90.0, 180.0, -135.0])
def test_converges_to_a_straight_line_from_any_heading(yaw):
    line = Line(start=(0.0, 0.0, -10.0), velocity=(1.0, 0.0, 0.0))
    log = run_alone(line, spatial_start((0.0, 8.0, -4.0), (0, 0, yaw)), 120.0)
    assert shifted_error(log[-200:]).max() < 0.05


@pytest.mark.parametrize("yaw", [0.0, 120.0, -90.0])
def test_planar_vehicle_follows_a_lawnmower_survey(yaw):
    survey = Lawnmower(origin=(0.0, 0.0, 0.0), leg_length=80.0, spacing=20.0, legs=3)
    log = run_alone(survey, planar_start((-5.0, 6.0), yaw), 200.0, planar=True)
    # After the transient: stays near the path through legs and turns (curvature 1/10 m^-1 makes a small offset).
    settled = shifted_error(log[round(60 / 0.05) :])
    assert settled.max() < 0.5
    assert log[-1].gamma > 150.0  # it really went round the turns


def test_still_converges_with_tight_actuator_limits():
    weak = replace(REMUS, max_surge_force=15.0, max_torque=3.0)
    log = run_alone(PAPER_HELIX, spatial_start((10.0, -15.0, -5.0)), 200.0, params=weak)
    tau = np.array([t.tau for t in log])
    assert np.abs(tau[:, 1:]).max() == pytest.approx(3.0)  # the limit was reached
    assert shifted_error(log[-400:]).max() < 0.05

"""A vehicle whose computer is down keeps moving (vehicles.coast): its plant with no inputs, carried by its momentum
and the current; the restarted controller starts at the path point nearest to where it got to (issue 28)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from supervisor.config.fleet import initial_state, radio, restarted_node, restore_state, vehicle_config
from supervisor.config.scenario import parse_scenario
from tests.conftest import CONFIGS
from vehicles.agent import UNDISTURBED
from vehicles.coast import coast, resumed
from vehicles.dynamics import PLANAR, SPATIAL
from vehicles.runtime import NodeState
from vehicles.step import step_records

PAPER = (CONFIGS / "paper.toml").read_text()
PLANAR_PAPER = (CONFIGS / "examples" / "planar_paper.toml").read_text()


def test_in_still_water_a_vehicle_glides_on_and_slows_under_its_drag():
    cfg = vehicle_config(parse_scenario(PAPER), 1)
    x0 = SPATIAL.pack(np.zeros(3), np.eye(3), np.array([1.5, 0.0, 0.0]), np.zeros(3))
    speeds, ahead = [], []
    for seconds in (2, 5, 20):
        x = SPATIAL.unpack(coast(cfg, x0, 0.0, seconds * 10, 0.1))
        speeds.append(float(np.linalg.norm(x.velocity)))
        ahead.append(float(x.position[0]))
    assert 1.5 > speeds[0] > speeds[1] > speeds[2] > 0.0  # slowing, never reversing
    assert 0.0 < ahead[0] < ahead[1] < ahead[2] < 1.5 * 20  # on along its heading, less far than at cruise


def test_a_vehicle_at_rest_drifts_with_the_current():
    sc = parse_scenario(PLANAR_PAPER, overrides=["environment.current=[0.2, -0.1, 0.0]"])
    cfg = vehicle_config(sc, 1)
    x0 = PLANAR.pack(np.array([3.0, 4.0]), np.eye(2), np.zeros(2), np.zeros(1))
    x = PLANAR.unpack(coast(cfg, x0, 10.0, 300, 0.1))
    np.testing.assert_allclose(x.position, [3.0 + 0.2 * 30, 4.0 - 0.1 * 30], atol=1e-9)
    np.testing.assert_allclose(x.velocity, [0.0, 0.0], atol=1e-12)  # it moves with the water, not through it


def test_the_restarted_controller_starts_at_the_path_point_nearest_the_coasted_vehicle():
    sc = parse_scenario(PAPER)
    cfg = vehicle_config(sc, 2)
    node = NodeState(initial_state(sc, cfg))
    for k in range(600):  # on its helix by now
        node, records = step_records(cfg, radio(sc, 2), node, k, k * 0.1, 0.1, [], [], UNDISTURBED)
    last = node.vehicle
    restarted = restarted_node(cfg, records.state, node.seq, 900, 0.1, sc.faults)
    state = restarted.vehicle
    assert state.t == pytest.approx(90.0) and restarted.nav is None and not state.estimates
    np.testing.assert_array_equal(state.x, resumed(cfg, restore_state(cfg, records.state), 301, 0.1).x)
    p = SPATIAL.unpack(state.x).position
    assert float(np.linalg.norm(p - SPATIAL.unpack(last.x).position)) > 1.0  # it moved while down
    p_d, slope, _ = cfg.path.evaluate_floats(state.gamma)
    error = p - np.array(p_d)
    assert abs(float(error @ np.array(slope))) < 1e-6 * float(np.linalg.norm(slope))  # nearest: error _|_ tangent
    assert abs(state.gamma - (last.gamma + 30 * last.gamma_dot)) < 100.0  # on its lap, not a period off
    assert 0.0 <= state.gamma_dot < last.gamma_dot  # it slowed while gliding


def test_coasting_is_deterministic_float_arithmetic():
    """The same bits from the same inputs, and no step leaves the attitude off SO(3)."""
    cfg = vehicle_config(parse_scenario(PAPER, overrides=["environment.current=[0.1, 0.05, 0.0]"]), 3)
    x0 = SPATIAL.pack(np.array([1.0, 2.0, -3.0]), np.eye(3), np.array([1.2, 0.1, 0.0]), np.array([0.0, 0.0, 0.1]))
    a, b = coast(cfg, x0, 5.0, 250, 0.1), coast(cfg, x0, 5.0, 250, 0.1)
    assert a.tolist() == b.tolist()
    rot = SPATIAL.unpack(a).rotation
    assert math.isclose(float(np.linalg.det(rot)), 1.0, abs_tol=1e-12)

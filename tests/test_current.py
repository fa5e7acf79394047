"""The ocean current (vehicles.current) and how the plant moves in it (vehicles.plant): against closed forms.

A vehicle that does not push drifts with the water: its velocity relative to the water decays by its surge damping,
    m u_r' = -(X_u + X_u|u| |u_r|) u_r,
from u_r(0) = -v_c (at rest over ground), and its position over ground is p(t) = v_c t + int u_r.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import parse_scenario
from tests.conftest import CONFIGS
from vehicles.agent import step
from vehicles.current import Current, body, feedforward
from vehicles.dynamics import PLANAR, SPATIAL, Model, reorthonormalize
from vehicles.geometry import rotation_from_rpy
from vehicles.params import PRESETS
from vehicles.plant import plant_rates
from vehicles.vehicle_model import Remus100Neutral

NEUTRAL = replace(PRESETS["remus100"], buoyancy=PRESETS["remus100"].weight)


def drift_closed_form(speed: float, t: float) -> tuple[float, float]:
    """(u_r, x) at t for a vehicle heading along +x, starting at rest over ground in a current speed along +x."""
    m, a, b = NEUTRAL.mass[0], NEUTRAL.linear_damping[0], NEUTRAL.quadratic_damping[0]
    lam, k = a / m, a / speed + b  # w = -u_r solves m w' = -(a + b w) w: w = a / (k e^(lam t) - b)
    w = a / (k * math.exp(lam * t) - b)
    travelled = (m / b) * math.log((k - b * math.exp(-lam * t)) / (a / speed))  # int_0^t w
    return -w, speed * t - travelled


def coast(model: Model, current: Current, seconds: float, dt: float = 0.05) -> list[float]:
    """RK4 of the plant with zero input from rest over ground (v_r = -R' v_c), heading +x."""
    angular = np.zeros(3 if model.dim == 3 else 1)
    s = model.lift(model.pack(np.zeros(model.dim), np.eye(model.dim), np.zeros(model.dim), angular))
    s[12:15] = [-c for c in current.velocity(0.0, 0.0)]
    t = 0.0
    for _ in range(round(seconds / dt)):
        ks: list[tuple[float, ...]] = []
        for h in (0.0, dt / 2, dt / 2, dt):
            point = s if not ks else [a + h * b for a, b in zip(s, ks[-1], strict=True)]
            ks.append(
                plant_rates(Remus100Neutral(dimension=model.dim), NEUTRAL, current, t + h, point, None, (0.0, 0.0, 0.0))
            )
        s = [a + dt / 6 * (b1 + 2 * b2 + 2 * b3 + b4) for a, b1, b2, b3, b4 in zip(s, *ks, strict=True)]
        s = reorthonormalize(s)
        t += dt
    return s


@pytest.mark.parametrize("model", [SPATIAL, PLANAR], ids=["spatial", "planar"])
@pytest.mark.parametrize("seconds", [5.0, 30.0, 120.0])
def test_a_vehicle_without_thrust_drifts_to_the_current_as_its_surge_damping_says(model, seconds):
    current = Current((0.3, 0.0, 0.0))
    s = coast(model, current, seconds)
    u_r, x = drift_closed_form(0.3, seconds)
    np.testing.assert_allclose(s[12], u_r, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(s[0], x, rtol=1e-6)
    assert abs(s[1]) < 1e-12 and abs(s[13]) < 1e-12  # no sway: the current is along the heading


def test_drift_reaches_the_current_velocity_over_ground_in_any_direction():
    current = Current((0.1, -0.2, 0.0))
    s = coast(SPATIAL, current, 600.0)
    ground = [s[3] * s[12] + s[4] * s[13] + s[5] * s[14] + 0.1, s[6] * s[12] + s[7] * s[13] + s[8] * s[14] - 0.2]
    np.testing.assert_allclose(ground, [0.1, -0.2], atol=2e-3)  # p_dot -> v_c
    assert math.hypot(s[12], s[13]) < 2e-3  # v_r -> 0


def test_the_field_adds_tide_and_shear_and_its_rate_is_their_derivative():
    current = Current((0.1, 0.0, 0.0), (0.2, 0.1, 0.0), 100.0, 0.3, (0.01, -0.02), -5.0)
    vx, vy, vz = current.velocity(12.5, 3.0)
    tide = math.sin(2 * math.pi * 12.5 / 100.0 + 0.3)
    np.testing.assert_allclose((vx, vy, vz), (0.1 + 0.2 * tide + 0.01 * 8.0, 0.1 * tide - 0.02 * 8.0, 0.0))
    h, z_dot = 1e-5, 0.4
    ahead, behind = current.velocity(12.5 + h, 3.0 + z_dot * h), current.velocity(12.5 - h, 3.0 - z_dot * h)
    numeric = [(a - b) / (2 * h) for a, b in zip(ahead, behind, strict=True)]
    np.testing.assert_allclose(current.rate(12.5, 3.0, z_dot), numeric, rtol=1e-6, atol=1e-12)


def test_the_feedforward_is_the_body_current_and_its_derivative_along_the_motion():
    current = Current((0.1, 0.05, 0.0), (0.2, 0.0, 0.01), 50.0, 0.0, (0.02, 0.0), 0.0)
    rot = rotation_from_rpy(0.1, -0.2, 0.7)
    x = SPATIAL.pack(np.array([1.0, 2.0, -3.0]), rot, np.array([0.8, 0.1, -0.05]), np.array([0.02, -0.03, 0.1]))
    s, t, h = SPATIAL.lift(x), 7.0, 1e-5
    c, c_dot = feedforward(current, t, s)
    tau = (0.0, 0.0, 0.0)
    xdot = plant_rates(Remus100Neutral(), NEUTRAL, current, t, s, None, tau)
    ahead = [a + h * b for a, b in zip(s, xdot, strict=True)]
    behind = [a - h * b for a, b in zip(s, xdot, strict=True)]
    numeric = [(a - b) / (2 * h) for a, b in zip(feedforward(current, t + h, ahead)[0],
                                                  feedforward(current, t - h, behind)[0], strict=True)]  # fmt: skip
    np.testing.assert_allclose(c, body(s[3:12], current.velocity(t, -3.0)))
    np.testing.assert_allclose(c_dot, numeric, rtol=1e-5, atol=1e-10)


# --- path following in a current -------------------------------------------------------------------------------


def follow(current: str, known: bool, seconds: float = 300.0) -> list[tuple[float, float]]:
    """(t, |p - p_d|) of AUV 1 of the paper scenario alone (no neighbours) in the given current, told to its
    controller or not; not told, the controller does not estimate it either (the observer is
    tests/test_current_observer.py's)."""
    text = (CONFIGS / "paper.toml").read_text()
    told = f"environment.current_known={str(known).lower()}"
    sc = parse_scenario(text, overrides=[f"environment.current={current}", told, "environment.estimate_current=off"])
    cfg = vehicle_config(sc, 1)
    state = initial_state(sc, cfg)
    out = []
    for _ in range(round(seconds / sc.scenario.step)):
        state, tel = step(cfg, state, sc.scenario.step, [])
        out.append((tel.t, float(np.linalg.norm(tel.error))))
    return out


def unknown_current_tube(speed: float, delta: float, k1: float, k_zeta: float, k2: float) -> float:
    """The tube an unknown current of this speed leaves (vehicles.path_following): V_dot <= -k1 |sigma|^2 + |sigma|
    speed - k_zeta zeta^2 - k2 |z2|^2 is negative outside |sigma| <= speed / k1, zeta^2 <= speed^2 / (4 k1 k_zeta),
    |z2|^2 <= speed^2 / (4 k1 k2), where V is at most V*; rho - 1 <= V* then bounds |z1|, and |p - p_d| <=
    |delta| + |z1|."""
    s = speed / k1
    v_star = (1 / math.sqrt(1 - s * s) - 1) + speed**2 / (8 * k1 * k_zeta) + speed**2 / (8 * k1 * k2)
    return abs(delta) + math.sqrt((1 + v_star) ** 2 - 1)


def test_an_unknown_current_leaves_the_vehicle_in_the_tube_lyapunov_gives():
    tube = unknown_current_tube(0.1, -1.0, 0.5, 1.0, 1.0)  # paper.toml's gains
    assert 1.2 < tube < 1.25
    assert round(unknown_current_tube(0.2, -1.0, 0.5, 1.0, 1.0), 2) == 1.48  # the README's number
    after = [e for t, e in follow("[0.1, 0.0, 0.0]", known=False) if t >= 100.0]
    still = [e for t, e in follow("[0.0, 0.0, 0.0]", known=False) if t >= 100.0]
    assert max(after) <= tube
    assert max(abs(e - s) for e, s in zip(after, still, strict=True)) > 0.02  # the current does push it


def test_a_known_current_is_fed_forward_and_the_tube_is_as_in_still_water():
    known = [e for t, e in follow("[0.1, 0.0, 0.0]", known=True) if t >= 100.0]
    still = [e for t, e in follow("[0.0, 0.0, 0.0]", known=True) if t >= 100.0]
    unknown = [e for t, e in follow("[0.1, 0.0, 0.0]", known=False) if t >= 100.0]
    gap_known = max(abs(a - b) for a, b in zip(known, still, strict=True))
    gap_unknown = max(abs(a - b) for a, b in zip(unknown, still, strict=True))
    assert gap_known < gap_unknown / 5

"""Fins and propeller between the controller and the vehicle (vehicles.actuators, [vehicle] actuators): within their
limits the vehicle gets what the controller asks for once the lags have passed; the fins' moment is bounded by
L u|u| max_deflection (Prestero's REMUS 100 numbers), the servo and the propeller follow their time constants; a
REMUS 100 with its own actuators cannot fly the paper's slow helices (the measured reason the paper's example keeps
ideal actuators); the summary and metrics.json say how long each input sat at its limit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import parse_scenario
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS
from vehicles.actuators import START, Actuators, remus100
from vehicles.agent import step
from vehicles.params import PRESETS
from vehicles.vehicle_model import Auv

FINS = remus100(max_thrust=14.1)


def settle(act: Actuators, commanded, u: float, seconds: float, dt: float = 0.01):
    """The actuators' state after holding commanded at speed u for seconds (explicit Euler, small steps)."""
    a = list(START)
    for _ in range(round(seconds / dt)):
        a = [x + dt * r for x, r in zip(a, act.rates(a, commanded, u), strict=True)]
    return a


def test_within_their_limits_the_vehicle_gets_what_is_asked_once_the_lags_have_passed():
    wanted = (5.0, 0.4, -0.3)  # N, N m, N m: within 14.1 N and 6.15 * 1.5^2 * 13.6 deg = 3.3 N m
    applied = FINS.applied(settle(FINS, wanted, 1.5, 20.0), 1.5)
    assert applied == pytest.approx(wanted, rel=1e-6)


def test_the_fin_moment_is_bounded_by_the_flow_and_the_deflection_limit():
    """Prestero's M_uu_delta_s = 6.15 kg/rad and +-13.6 deg: 1.46 N m at 1 m/s, 0.37 at 0.5, 9.1 at 2.5 m/s."""
    assert FINS.torque_limit(1.0) == pytest.approx(6.15 * math.radians(13.6))
    assert FINS.torque_limit(2.5) == pytest.approx(9.13, abs=0.01)
    for u in (0.5, 1.0, 2.5):
        applied = FINS.applied(settle(FINS, (0.0, 50.0, -50.0), u, 20.0), u)
        assert applied[1] == pytest.approx(FINS.torque_limit(u), rel=1e-6)
        assert applied[2] == pytest.approx(-FINS.torque_limit(u), rel=1e-6)
    assert FINS.applied(settle(FINS, (0.0, 50.0, 50.0), 0.0, 20.0), 0.0)[1:] == (0.0, 0.0)  # no flow, no moment


@pytest.mark.parametrize("index", [0, 2])
def test_the_servo_and_the_propeller_follow_their_time_constants(index):
    """First-order lags of 0.1 s (fins) and 1 s (propeller) (Fossen's T_delta, T_n): 1 - 1/e of a step after one
    time constant."""
    target = (14.1, 0.0, 0.0) if index == 2 else (0.0, 0.5, 0.0)
    tau = FINS.thruster_time_constant if index == 2 else FINS.fin_time_constant
    assert tau == (1.0 if index == 2 else 0.1)
    end = settle(FINS, target, 1.0, 50.0)[index]
    at_tau = settle(FINS, target, 1.0, tau, dt=tau / 100)[index]
    assert at_tau / end == pytest.approx(1.0 - math.exp(-1.0), abs=0.01)


def test_a_rate_limit_bounds_the_fin_rate():
    limited = Actuators(6.15, math.radians(13.6), 0.1, 1.0, 14.1, max_rate=math.radians(10.0))
    rate = limited.rates(START, (0.0, 100.0, 0.0), 1.0)[0]
    assert rate == pytest.approx(math.radians(10.0))


def _run(text: str, seconds: float, *sets: str):
    sc = parse_scenario(text, "s.toml", list(sets))
    cfg = vehicle_config(sc, 1)
    state = initial_state(sc, cfg)
    errors = []
    for _ in range(round(seconds / sc.scenario.step)):
        state, tel = step(cfg, state, sc.scenario.step, [])
        errors.append(float(np.linalg.norm(tel.error)))
    return cfg, errors


def test_it_cannot_fly_the_paper_helices_which_keep_ideal_actuators():
    """The paper's helices are flown at 0.24-0.40 m/s, where the fins give 0.1-0.35 N m and holding them needs
    0.75-1.2 N m (issue 24): the vehicle leaves its path."""
    paper = (CONFIGS / "paper.toml").read_text()
    _, real = _run(paper, 150.0, 'vehicle.actuators="remus100"')
    _, ideal = _run(paper, 150.0)
    assert max(ideal[500:]) < 1.2
    assert max(real[500:]) > 3.0


@pytest.mark.parametrize(("preset", "pole"), [("remus100_neutral", 1.30), ("remus100", 0.395)])
def test_running_straight_the_remus_is_unstable_in_sway_yaw_and_its_lift_slows_the_pole_threefold(preset, pole):
    """Linearised about a straight run at 1 m/s, the sway-yaw pair of the paper's model with a REMUS 100's masses
    (remus100_neutral; its drift, numerically differentiated) has an unstable pole of 1.3 1/s: the Munk moment
    (M_22 - M_11) u v, unopposed by the hull's and fins' lift the model leaves out. With Prestero's lift (remus100)
    the pair is still unstable, as a torpedo hull with small fins is, at 0.395 1/s, and the fins fly it (no
    controller here flies the lift-free model on them: tests/test_lift.py). The poles follow from the coefficients
    in closed form: det [[(-d_v + Y_uv u) / m_v - s, (Y_ur - m_u) u / m_v], [(N_uv + m_u - m_v) u / J,
    (-d_r + N_ur u) / J - s]] = 0."""
    model, prm, h = Auv(dimension=2), PRESETS[preset], 1e-6
    straight = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]

    def rates(v: float, r: float) -> tuple[float, float]:
        (_, v_dot, _), (_, _, r_dot) = model.drift([*straight[:13], v, 0.0, 0.0, 0.0, r], prm)
        return v_dot, r_dot

    columns = [
        np.subtract(rates(h, 0.0), rates(-h, 0.0)) / (2 * h),
        np.subtract(rates(0.0, h), rates(0.0, -h)) / (2 * h),
    ]
    fastest = max(np.linalg.eigvals(np.column_stack(columns)).real)
    assert fastest == pytest.approx(pole, abs=0.005)
    (m_u, m_v, _), j = prm.mass, prm.inertia[2]
    closed = [
        [(-prm.linear_damping[1] + prm.lift_uv) / m_v, (prm.lift_ur - m_u) / m_v],
        [(prm.lift_moment_uv + m_u - m_v) / j, (-prm.angular_linear_damping[2] + prm.lift_moment_ur) / j],
    ]
    assert fastest == pytest.approx(max(np.linalg.eigvals(np.array(closed)).real), abs=1e-4)  # v|v| at h: 2e-6


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ('vehicle.actuators="fins"', "vehicle.actuators: must be 'preset', 'ideal' or 'remus100', got 'fins'"),
        (
            "vehicle.actuators={max_deflection_deg = 0}",
            "vehicle.actuators.max_deflection_deg: must be greater than 0, got 0",
        ),
        ("vehicle.actuators={lift = 3}", "vehicle.actuators.lift: unknown key"),
    ],
)
def test_bad_actuators_are_one_line_errors(setting, message):
    with pytest.raises(ScenarioError) as err:
        parse_scenario((CONFIGS / "paper.toml").read_text(), "paper.toml", [setting])
    assert message in str(err.value) and "\n" not in str(err.value)


def test_time_at_the_input_limits_is_counted_from_the_recorded_inputs_and_speed():
    """Ideal actuators: at the constant limits; fins: at L u^2 max_deflection for the recorded speed (within 1 %)."""
    from supervisor.analysis.input_limits import at_input_limits, format_input_limits, input_limits_metrics
    from supervisor.analysis.summary import Series

    paper = (CONFIGS / "paper.toml").read_text()
    t = np.arange(10, dtype=np.float64) * 0.1
    gamma = np.zeros((10, 3))
    inputs = np.zeros((10, 3, 3))
    surge = np.full((10, 3), 1.0)
    inputs[:4, 2, 0] = -20.0  # vehicle 1: yaw at the preset's 20 N m for 0.4 s
    inputs[:, 0, 1] = 14.0  # vehicle 2: surge within 1 % of its 14.1 N the whole second
    inputs[:5, 1, 2] = FINS.torque_limit(1.0)  # vehicle 3: at the fins' limit at 1 m/s; ideal: far below 20 N m
    series = Series((1, 2, 3), t, gamma, gamma, gamma, inputs, surge)
    ideal = at_input_limits(parse_scenario(paper, "paper.toml", []), series)
    fins = at_input_limits(parse_scenario(paper, "paper.toml", ['vehicle.actuators="remus100"']), series)
    assert ideal is not None and fins is not None
    assert ideal[0].seconds == pytest.approx((0.0, 0.0, 0.4))
    assert ideal[1].seconds == pytest.approx((1.0, 0.0, 0.0))
    assert ideal[2].seconds == pytest.approx((0.0, 0.0, 0.0))
    assert fins[2].seconds == pytest.approx((0.0, 0.5, 0.0))
    assert format_input_limits(ideal) == (
        "vehicle 1: inputs at their limits for yaw 40 % of its time\n"
        "vehicle 2: inputs at their limits for surge 100 % of its time"
    )
    table = input_limits_metrics(fins)["inputs_at_limit"]
    assert isinstance(table, dict) and table["3"] == {"surge": 0.0, "pitch": 0.5, "yaw": 0.0, "alive": 1.0}


def test_the_vehicle_moves_with_what_the_actuators_give_not_with_what_was_asked():
    """From rest the propeller's thrust builds up over its 1 s lag: the state records the inputs the actuators gave
    (none at the first instant) and the vehicle is slower after 1 s than with ideal actuators, which give what is
    asked at once."""
    paper = (CONFIGS / "paper.toml").read_text()
    speeds, first = {}, {}
    for name in ("ideal", "remus100"):
        sc = parse_scenario(paper, "paper.toml", [f'vehicle.actuators="{name}"'])
        cfg = vehicle_config(sc, 1)
        state = initial_state(sc, cfg)
        for k in range(10):
            state, tel = step(cfg, state, 0.1, [])
            if k == 0:
                first[name] = float(tel.tau[0])
        speeds[name] = float(state.x[12])
    assert first["ideal"] > 1.0 and first["remus100"] == 0.0
    assert 0.0 < speeds["remus100"] < 0.8 * speeds["ideal"]

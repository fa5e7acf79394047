"""vehicles.turn, the yaw moment a steady turn takes, against the simulator: the remus100 on circles flown at 1.5 m/s
holds the moment it predicts where its rudder suffices, sits at its max_torque where the circle is tighter than the
least radius it predicts, and flies wide of its path there; `cpf validate` says which (supervisor.config.turn_checks).
"""

from __future__ import annotations

import io
import math
from functools import cache

import numpy as np
import pytest

from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_checks import scenario_warnings
from supervisor.config.turn_checks import turn_warnings
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from vehicles.params import PRESETS
from vehicles.turn import fastest_turn, turn
from vehicles.vehicle_model import Remus100

REMUS, MODEL = PRESETS["remus100"], Remus100()
SPEED = 1.5  # m/s along the circles: v_r 1 with a period of 2 pi R / 1.5
LEAST = SPEED / fastest_turn(MODEL, REMUS, SPEED, (REMUS.max_torque, math.inf), 2.0)  # m: by the rudder alone
SETTLED = 60.0  # s: the turn steady after it


def circles(radius: float) -> str:
    period = 2 * math.pi * radius / SPEED
    vehicles = "".join(
        f'\n[[vehicles]]\nid = {i}\nposition = [{radius}, 0.0, 0.0]\npath = {{ type = "circle", radius = {radius}, '
        f"period = {period!r} }}\n"
        for i in (1, 2)
    )
    return (
        '[scenario]\nname = "turn"\nduration = 120.0\nstep = 0.05\ndimension = 2\n[vehicle]\npreset = "remus100"\n'
        'actuators = "ideal"\n[graph]\nedges = [[1, 2]]\n' + vehicles
    )


@cache
def flown(radius: float) -> tuple[np.ndarray, float]:
    """Vehicle 1's yaw moment over the settled turn, and its largest path-following error then."""
    sc = parse_scenario(circles(radius), "turn.toml")
    series = run_inprocess(sc, "turn.toml", "", None, 0, Progress(120.0, io.StringIO(), enabled=False)).series
    settled = series.t >= SETTLED
    assert series.inputs is not None
    return series.inputs[settled, 2, 0], float(np.nanmax(series.path_error[settled, 0]))


def test_the_least_radius_at_1_5_m_per_s_is_3_04_m():
    """The number the module docstring and the warning give (max_torque 20 N m)."""
    assert round(LEAST, 2) == 3.04


@pytest.mark.parametrize("radius", [3.3, 4.0])
def test_where_the_rudder_suffices_the_vehicle_holds_the_moment_the_turn_predicts(radius: float):
    """The steady turn's moment at the path's speed and yaw rate is the simulated vehicle's, within 3 % (10.6 N m
    on a circle of 4 m, 16.6 on one of 3.3: the controller's delta leaves the speed a little higher)."""
    found = turn(MODEL, REMUS, SPEED, SPEED / radius)
    moments, _ = flown(radius)
    assert found is not None and abs(found.moment) < REMUS.max_torque
    assert np.abs(moments) == pytest.approx(abs(found.moment), rel=0.03)
    assert not turn_warnings(parse_scenario(circles(radius), "turn.toml"))


@pytest.mark.parametrize("radius", [2.0, 2.8])
def test_a_circle_tighter_than_the_least_radius_is_warned_of_and_not_flown(radius: float):
    """Below 3.04 m the rudder sits at its limit the whole settled turn and the vehicle flies wide: on 2 m it leaves
    its 1.2 m tube (1.65 m off), on 2.8 m it stays inside it (1.10 m off, against 1.00 on a circle it can fly)."""
    moments, error = flown(radius)
    assert np.all(np.abs(moments) >= REMUS.max_torque - 1e-9)
    assert error > flown(4.0)[1] + 0.05
    scenario = parse_scenario(circles(radius), "turn.toml")
    warnings = turn_warnings(scenario)
    assert len(warnings) == 2 and all("no tighter than a radius of 3.04 m" in w for w in warnings), warnings
    assert set(warnings) <= set(scenario_warnings(scenario))  # what cpf validate and cpf run say


@pytest.mark.parametrize(("spacing", "warned"), [(2.0, True), (8.0, False)])
def test_a_lawnmowers_turns_are_judged_though_its_legs_are_straight(spacing, warned):
    """A survey's semicircles of radius spacing / 2 are a small part of it: sampled evenly, every sample fell on a
    leg and 1 m turns at 1.5 m/s passed (the review); 4 m turns are within the remus100's 3.04 m."""
    text = (
        circles(4.0)
        .replace(
            'path = { type = "circle", radius = 4.0, period = ' + repr(2 * math.pi * 4.0 / SPEED) + " }",
            f'path = {{ type = "lawnmower", origin = [0.0, 0.0, 0.0], leg_length = 210.0, spacing = {spacing}, '
            "legs = 8 }",
        )
        .replace("duration = 120.0", "duration = 1000.0")
    )
    sc = parse_scenario(text, "turn.toml", ["coordination.v_r=1.5"])
    warnings = turn_warnings(sc)
    assert bool(warnings) == warned, warnings
    assert not warned or "got a turn of radius 1 m" in warnings[0]


def test_the_readmes_turn_figures():
    """README ("Robust vehicles"): the moments held on 4 and 3.3 m, the errors on 4, 2.8 and 2 m, to their digits."""
    assert [round(float(np.mean(np.abs(flown(r)[0]))), 1) for r in (4.0, 3.3)] == [10.6, 16.6]
    assert [round(flown(r)[1], 2) for r in (4.0, 2.8, 2.0)] == [1.00, 1.10, 1.65]


def test_a_vehicle_held_to_its_top_speed_turns_at_that_speed():
    """[saturation] top_speed 0.8 m/s on the 2 m circle: gamma_dot is held, the turn is 0.4 rad/s, within the rudder
    (it flew 0.6 m off with the rudder never at its limit, and validate warned of 1.5 m/s: a new user)."""
    assert not turn_warnings(parse_scenario(circles(2.0), "turn.toml", ["saturation.top_speed=0.8"]))


def test_a_lawnmower_is_judged_from_where_the_vehicle_starts_on_it():
    """gamma0 = "closest" on a lawnmower was judged from gamma 0 (a path not periodic taken as straight near its
    start): vehicles starting 280 m along 300 m legs, their run of 225 m crossing 1 m turns, were not warned of."""
    lawnmower = '{ type = "lawnmower", origin = [0.0, 0.0, 0.0], leg_length = 300.0, spacing = 2.0, legs = 6 }'
    text = (
        circles(4.0)
        .replace(
            'path = { type = "circle", radius = 4.0, period = ' + repr(2 * math.pi * 4.0 / SPEED) + " }",
            f"path = {lawnmower}",
        )
        .replace("position = [4.0, 0.0, 0.0]", "position = [280.0, 0.0, 0.0]")
    )
    sc = parse_scenario(text.replace("duration = 120.0", "duration = 150.0"), "turn.toml", ["coordination.v_r=1.5"])
    assert len(turn_warnings(sc)) == 2


@cache
def on_fins(radius: float) -> tuple[list[str], float]:
    """The remus100 on its fins in 3-D at 1 m/s with the default controller (line_of_sight) on a circle: the turn
    warnings, and the largest path error after 150 s of 300."""
    text = circles(radius).replace('actuators = "ideal"\n', "").replace("dimension = 2", "dimension = 3")
    sc = parse_scenario(
        text.replace("duration = 120.0", "duration = 300.0"), "turn.toml", [f"coordination.v_r={1 / SPEED!r}"]
    )
    series = run_inprocess(sc, "turn.toml", "", None, 0, Progress(300.0, io.StringIO(), enabled=False)).series
    return turn_warnings(sc), float(np.nanmax(series.path_error[series.t >= 150.0, 0]))


def test_line_of_sight_turns_within_its_own_bound_and_the_check_says_where():
    """line_of_sight keeps its rates within half of what its fins give (vehicles/line_of_sight.py), so at 1 m/s on
    fins it turns no tighter than 9.89 m though its rudder could hold 6.3 m: a new user's 7 m circles flew 7 m off,
    unwarned. Its turn_rate_bound says so: at 10.3 m it follows the circle to the centimetre and nothing is said; at
    9.5 m it is warned of and flies 0.69 m wide."""
    warned, error = on_fins(9.5)
    assert len(warned) == 2 and "line_of_sight asks for at most 0.101 rad/s" in warned[0], warned
    assert "no tighter than a radius of 9.89 m" in warned[0] and error > 0.5
    clean, error = on_fins(10.3)
    assert not clean and error < 0.05


@cache
def neutral(radius: float) -> tuple[list[str], float, float]:
    """remus100_neutral on the circle at 1.5 m/s: its turn warnings, and over the settled turn its largest surge
    force [N] and mean surge speed [m/s]."""
    sc = parse_scenario(circles(radius).replace('"remus100"', '"remus100_neutral"'), "turn.toml")
    series = run_inprocess(sc, "turn.toml", "", None, 0, Progress(120.0, io.StringIO(), enabled=False)).series
    settled = series.t >= SETTLED
    assert series.inputs is not None and series.surge is not None
    return turn_warnings(sc), float(np.max(series.inputs[settled, 0, 0])), float(np.mean(series.surge[settled, 0]))


def test_a_turn_the_propeller_cannot_drive_is_warned_of():
    """A turn's slip drags: remus100_neutral (14.1 N of thrust) on a 3.5 m circle at 1.5 m/s needs 15.5 N; it sat at
    its thrust limit and slowed to 1.39 m/s, unwarned (a new user: 2.5 m, 1.38 m off). On 4.5 m it needs 12.8 N and
    keeps its speed. (The turn is judged at the path's speed; the vehicle, |delta| behind its point, flies a little
    faster: on 4 m, just outside the 3.89 m said, its propeller is at its limit and it slows by 0.3 %.)"""
    warned, thrust, speed = neutral(3.5)
    assert len(warned) == 2 and "a thrust of 15.5 N (it has 14.1: it slows down)" in warned[0], warned
    assert "no tighter than a radius of 3.89 m" in warned[0]
    assert thrust == pytest.approx(PRESETS["remus100_neutral"].max_surge_force) and speed < 1.4
    clean, thrust, speed = neutral(4.5)
    assert not clean and thrust < 13.0 and speed == pytest.approx(SPEED, abs=1e-3)

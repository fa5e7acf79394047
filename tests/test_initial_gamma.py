"""gamma0 = "closest": where each vehicle starts along its path, and that a fleet started side by side agrees.

The rule (config.fleet.initial_gamma, vehicles.nearest.nearest_gamma): the first vehicle takes its nearest point
within half a period of gamma = 0 (a circle or helix) or on its whole path (a line or lawnmower); every other vehicle
on a circle or helix takes its nearest point within half a period of the first vehicle's gamma0, on a line or
lawnmower the nearest point of its whole path. Ties: the point nearest that reference.

        o o o o o o o o  ->        eight AUVs side by side, each on its own circle (same centre, radii differ),
     (  (  (  (  (  (  (  (        must start with (nearly) equal gammas wherever along the circles they start.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from supervisor.config.fleet import build_path, initial_state, vehicle_config
from supervisor.config.scenario import load_scenario, parse_scenario
from supervisor.config.scenario_schema import CirclePath, HelixPath, Scenario, VehicleSection
from vehicles.nearest import nearest_gamma, search_interval
from vehicles.paths import Circle, Helix, Lawnmower, Line
from vehicles.paths import Path as PathModel

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the benchmarks' scenario builders
from benchmarks.bench_scaling import ring_scenario  # noqa: E402
from tests.test_scenario import FOURTH_VEHICLE, PAPER  # noqa: E402

SIDE = 1.0  # m: how far off its path each vehicle starts, sideways (the nearest point stays where it was)
SMALL = 1e-6  # the largest spread of gammas of a fleet started side by side, relative to its period or extent


def scenario_text(name: str, vehicles: list[tuple[tuple[float, float, float], str]], dimension: int = 3) -> str:
    """A scenario of vehicles (start position, path as an inline TOML table) on a line graph."""
    edges = [[i, i + 1] for i in range(1, len(vehicles))]
    head = f'[scenario]\nname = "{name}"\nduration = 10.0\nstep = 0.1\ndimension = {dimension}\n\n'
    head += f"[graph]\nedges = {edges}\n"
    body = "".join(
        f"\n[[vehicles]]\nid = {i}\nposition = [{x!r}, {y!r}, {z!r}]\npath = {path}\n"
        for i, ((x, y, z), path) in enumerate(vehicles, start=1)
    )
    return head + body


def circles(n: int = 8, period: float = 400.0, phase: float = 0.0) -> str:
    paths = [
        f'{{ type = "circle", radius = {20.0 + 5.0 * i}, period = {period}, phase_rad = {phase} }}' for i in range(n)
    ]
    return scenario_text("circles", [((22.0 + 5.0 * i, -3.0, 0.0), p) for i, p in enumerate(paths)])


def helices(n: int = 6) -> str:
    # Climbs that differ, so a lap away is a different height for each: the nearest lap is not the same for all.
    paths = [
        f'{{ type = "helix", radius = {15.0 + 5.0 * i}, climb = {0.001 * (i + 1)}, period = 400.0, phase_rad = 1.0 }}'
        for i in range(n)
    ]
    return scenario_text("helices", [((2.0 + 5.0 * i, 20.0 + 5.0 * i, 1.0), p) for i, p in enumerate(paths)])


def lawnmowers(n: int = 6, legs: int = 12) -> str:
    pattern = f"leg_length = 200.0, spacing = 20.0, legs = {legs}"
    paths = [f'{{ type = "lawnmower", origin = [0.0, {250.0 * i}, -10.0], {pattern} }}' for i in range(n)]
    return scenario_text("lawnmowers", [((-5.0, 250.0 * i - 3.0, -10.0), p) for i, p in enumerate(paths)])


def lines(n: int = 5, speed: float = 0.5) -> str:
    paths = [f'{{ type = "line", start = [0.0, {10.0 * i}, -5.0], velocity = [{speed}, 0.0, 0.0] }}' for i in range(n)]
    return scenario_text("lines", [((-3.0 + i, 10.0 * i + 2.0, -4.0), p) for i, p in enumerate(paths)])


def planar_circles() -> str:
    paths = [f'{{ type = "circle", radius = {30.0 + 10.0 * i}, period = -300.0, phase_rad = 2.0 }}' for i in range(4)]
    return scenario_text("planar", [((0.0, -31.0 - 10.0 * i, 0.0), p) for i, p in enumerate(paths)], dimension=2)


BUILT = {
    "circles": circles(),
    "helices": helices(),
    "lawnmowers": lawnmowers(),
    "lines": lines(),
    "planar circles": planar_circles(),
    "paper plus a circle": PAPER.replace("[[1, 2], [1, 3]]", "[[1, 2], [1, 3], [3, 4]]") + FOURTH_VEHICLE,
    "ring of lines (benchmark)": ring_scenario(6, 10.0),
}
SHIPPED = sorted((ROOT / "configs").rglob("*.toml"))  # the examples too


def every_scenario() -> list[tuple[str, Scenario]]:
    shipped = [(path.name, load_scenario(path)) for path in SHIPPED]
    return shipped + [(name, parse_scenario(text, f"{name}.toml")) for name, text in BUILT.items()]


def gammas(scenario: Scenario) -> list[float]:
    return [initial_state(scenario, vehicle_config(scenario, i)).gamma for i in scenario.vehicle_ids]


def side_by_side(scenario: Scenario, anchor: float) -> Scenario:
    """The scenario with every vehicle started SIDE metres sideways of its path's point at gamma = anchor."""
    vehicles = []
    for section in scenario.vehicles:
        path = build_path(section.path)
        start = sideways(path, anchor, SIDE)
        if scenario.scenario.dimension == 2:
            start[2] = section.position[2]  # a planar vehicle's z is not looked at: leave it as it was
        vehicles.append(section.model_copy(update={"position": tuple(float(v) for v in start), "gamma0": "closest"}))
    return scenario.model_copy(update={"vehicles": tuple(vehicles)})


def sideways(path: PathModel, gamma: float, offset: float) -> np.ndarray:
    """A point `offset` m from p_d(gamma), horizontally perpendicular to the path, away from the centre of the
    turn (so p_d(gamma) stays its nearest point)."""
    p, dp, d2p = path.evaluate(gamma)
    normal = np.array([dp[1], -dp[0], 0.0])
    normal /= np.linalg.norm(normal)
    if np.dot(normal, d2p) > 0:  # toward the centre of curvature: turn round
        normal = -normal
    return p + offset * normal


def moved(scenario: Scenario, where: Callable[[VehicleSection], tuple[float, float, float]]) -> Scenario:
    """The scenario with each vehicle started at where(its section)."""
    vehicles = tuple(s.model_copy(update={"position": where(s)}) for s in scenario.vehicles)
    return scenario.model_copy(update={"vehicles": vehicles})


def radius(section: VehicleSection) -> float:
    assert isinstance(section.path, CirclePath | HelixPath)
    return section.path.radius


def scale_of(scenario: Scenario) -> float:
    """What a spread of gammas is measured against: the first path's period, or its extent, or 1."""
    path = build_path(scenario.vehicles[0].path)
    if path.gamma_period is not None:
        return path.gamma_period
    a, b = path.straight_beyond or (0.0, 0.0)
    return max(b - a, 1.0)


def anchors(scenario: Scenario) -> list[float]:
    """Gammas along the first path to start the fleet at: over the period around gamma = 0, its seams (half a period
    either side) included, and laps away where the path comes back to the same place (a circle; a helix has climbed:
    its lap is chosen by the rule); over an aperiodic path's span and well beyond its ends."""
    path = build_path(scenario.vehicles[0].path)
    period = path.gamma_period
    if period is not None:
        laps = [-1.7, 2.35] if np.allclose(path.evaluate(0.3)[0], path.evaluate(0.3 + period)[0]) else []
        return [f * period for f in (-0.4999, -0.25, 0.0, 0.1, 0.3, 0.4999, 0.5, *laps)]
    a, b = path.straight_beyond or (0.0, 0.0)
    extent = max(b - a, 100.0)
    return [a - 0.3 * extent, a, a + 0.37 * extent, (a + b) / 2 + 0.1, b, b + 0.8 * extent, b + 3000.0]


@pytest.mark.parametrize(("name", "scenario"), every_scenario(), ids=lambda v: v if isinstance(v, str) else "")
def test_a_fleet_started_side_by_side_starts_with_nearly_equal_gammas(name: str, scenario: Scenario) -> None:
    for anchor in anchors(scenario):
        got = gammas(side_by_side(scenario, anchor))
        spread = max(got) - min(got)
        assert spread <= SMALL * scale_of(scenario), (name, anchor, got)


@pytest.mark.parametrize(("name", "scenario"), every_scenario(), ids=lambda v: v if isinstance(v, str) else "")
def test_as_written_every_vehicle_starts_at_its_nearest_point_on_the_fleets_lap(name: str, scenario: Scenario) -> None:
    """The spread as the scenario places its vehicles (the paper's start at different places) is the spread of
    their nearest points found by brute force, on the lap the rule names."""
    expected: list[float] = []
    tolerance: list[float] = []
    for section in scenario.vehicles:
        path = build_path(section.path)
        target = np.array(section.position, dtype=float)
        if scenario.scenario.dimension == 2:
            target[2] = float(path.evaluate(0.0)[0][2])
        reference = expected[0] if expected else 0.0
        if section.gamma0 == "closest":
            gamma, step = brute_force_nearest(path, target, reference)
        else:
            gamma, step = float(section.gamma0), 0.0
        expected.append(gamma)
        tolerance.append(2 * step + 1e-9)
    got = gammas(scenario)
    assert np.all(np.abs(np.array(got) - expected) <= tolerance), (got, expected)
    assert max(got) - min(got) == pytest.approx(max(expected) - min(expected), abs=2 * max(tolerance))


def brute_force_nearest(path: PathModel, point: np.ndarray, reference: float) -> tuple[float, float]:
    """Nearest point over the rule's interval by a dense scan (an independent check of the search; equally near
    points: the one nearest the reference), and the scan's step."""
    lo, hi = search_interval(path, point, reference)
    grid = np.linspace(lo, hi, 1_000_001)
    d = np.linalg.norm(path.positions(grid) - point, axis=1)
    near = grid[d <= d.min() + 1e-12 * max(float(d.min()), 1.0)]
    return float(near[np.argmin(np.abs(near - reference))]), float(grid[1] - grid[0])


# --- the cases of the issue, one by one ------------------------------------------------------------------------


@pytest.mark.parametrize("angle_deg", [0.0, 90.0, 179.9, 180.0, -179.9, 270.0])
def test_eight_auvs_on_concentric_circles_start_on_one_lap(angle_deg: float) -> None:
    """Period 400, radii 20 to 55 m, started 2 m outside their circles at the same bearing."""
    text = circles()
    scenario = parse_scenario(text, "circles.toml")
    a = math.radians(angle_deg)
    got = gammas(moved(scenario, lambda s: ((radius(s) + 2.0) * math.cos(a), (radius(s) + 2.0) * math.sin(a), 0.0)))
    assert max(got) - min(got) < 1e-6, got
    assert -200.0 <= got[0] <= 200.0  # the first vehicle: within half a period of gamma = 0
    assert got[0] == pytest.approx(400.0 * angle_deg / 360.0 - 400.0 * round(angle_deg / 360.0), abs=1e-6)


def test_helices_whose_laps_differ_in_height_still_start_on_one_lap() -> None:
    """Vehicles 3 m below their helices' start: for each climb another lap is nearest in 3-D, within the rule the
    fleet's lap is the first vehicle's."""
    scenario = parse_scenario(helices(), "helices.toml")
    moved = []
    for s in scenario.vehicles:
        p = sideways(build_path(s.path), 40.0, SIDE)
        moved.append(s.model_copy(update={"position": (float(p[0]), float(p[1]), float(p[2]) - 3.0)}))
    got = gammas(scenario.model_copy(update={"vehicles": tuple(moved)}))
    assert all(-160.0 <= g <= 240.0 for g in got), got  # within half a period of the first, on one lap
    assert max(got) - min(got) < 1.0, got  # 3 m below a 0.001-0.006 m/gamma climb moves little along the lap


def test_six_auvs_on_lawnmower_strips_of_a_long_survey_start_together_far_along_it() -> None:
    """Strips 250 m apart, 12 legs of 200 m (gamma up to 2572): started side by side on the ninth leg."""
    scenario = side_by_side(parse_scenario(lawnmowers(), "lawn.toml"), 1900.0)
    got = gammas(scenario)
    np.testing.assert_allclose(got, 1900.0, rtol=0, atol=1e-6)


def test_lawnmower_vehicles_between_two_legs_all_take_the_leg_nearest_the_reference() -> None:
    """Midway between legs 0 and 1 (equally near): every vehicle takes the first vehicle's choice."""
    scenario = parse_scenario(lawnmowers(legs=3), "lawn.toml")
    got = gammas(moved(scenario, lambda s: (50.0, build_path(s.path).evaluate(0.0)[0][1] + 10.0, -10.0)))
    np.testing.assert_allclose(got, 50.0, rtol=0, atol=1e-6)  # leg 0 at x = 50 (gamma = 0 is the reference)


def test_lines_started_far_along_start_at_their_nearest_points() -> None:
    """0.5 m per gamma, started 1500 m down the lines: gamma 3000 for all (nothing clips the search)."""
    scenario = side_by_side(parse_scenario(lines(), "lines.toml"), 3000.0)
    got = gammas(scenario)
    np.testing.assert_allclose(got, 3000.0, rtol=0, atol=1e-6)


def test_a_given_gamma0_of_the_first_vehicle_names_the_fleets_lap() -> None:
    text = circles(3).replace("id = 1\n", "id = 1\ngamma0 = 800.0\n")
    scenario = parse_scenario(text, "circles.toml")
    got = gammas(moved(scenario, lambda s: (radius(s) + 1.0, 0.5, 0.0)))
    assert got[0] == 800.0
    assert all(795.0 < g < 805.0 for g in got[1:]), got


# --- the search itself --------------------------------------------------------------------------------------------


def test_paths_say_their_period_and_where_they_run_straight() -> None:
    assert Circle(10.0, -300.0, 0.0).gamma_period == 300.0
    assert Helix(10.0, 0.1, 250.0, 0.0).gamma_period == 250.0
    assert Circle(10.0, 300.0, 0.0).straight_beyond is None
    line, mower = Line((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), Lawnmower((0.0, 0.0, 0.0), 100.0, 10.0, 3, scale=2.0)
    assert line.gamma_period is None and line.straight_beyond == (0.0, 0.0)
    assert mower.gamma_period is None and mower.straight_beyond == (0.0, mower.length / 2.0)


@pytest.mark.parametrize("reference", [0.0, 123.0, -950.0, 4000.0])
def test_on_a_circle_the_search_covers_one_period_around_the_reference(reference: float) -> None:
    circle = Circle(25.0, 400.0, 0.3)
    point = np.array([3.0, -40.0, 2.0])
    got = nearest_gamma(circle, point, reference)
    assert reference - 200.0 <= got <= reference + 200.0
    p = circle.evaluate(got)[0]
    expected_bearing = math.atan2(point[1], point[0])
    assert math.atan2(p[1], p[0]) == pytest.approx(expected_bearing, abs=1e-9)


def test_at_a_circles_centre_every_point_is_as_near_and_the_reference_wins() -> None:
    assert nearest_gamma(Circle(25.0, 400.0, 0.3), np.array([0.0, 0.0, 5.0]), 37.0) == pytest.approx(37.0, abs=0.5)


def test_a_lawnmowers_straight_ends_are_searched_as_far_as_needed() -> None:
    mower = Lawnmower((0.0, 0.0, 0.0), 100.0, 10.0, 2)
    assert nearest_gamma(mower, np.array([-5000.0, 3.0, 0.0])) == pytest.approx(-5000.0, abs=1e-6)
    end = mower.length
    beyond = mower.evaluate(end + 7000.0)[0] + np.array([0.0, 2.0, 0.0])
    assert nearest_gamma(mower, beyond) == pytest.approx(end + 7000.0, abs=1e-6)


def test_nearest_gamma_rejects_bad_input() -> None:
    line = Line((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="point must have shape"):
        nearest_gamma(line, np.zeros(2))
    with pytest.raises(ValueError, match="point must be finite"):
        nearest_gamma(line, np.array([0.0, math.nan, 0.0]))
    with pytest.raises(ValueError, match="reference must be finite"):
        nearest_gamma(line, np.zeros(3), math.inf)


class _Alone:
    """A path that does not take lanes: nearest_gamma evaluates it gamma by gamma."""

    def __init__(self, path: PathModel) -> None:
        self.path = path
        self.gamma_period, self.straight_beyond = path.gamma_period, path.straight_beyond

    def evaluate_floats(self, gamma: float):
        assert isinstance(gamma, float)
        return self.path.evaluate_floats(gamma)


_FINITE = st.floats(-1e4, 1e4, allow_nan=False)
_PATHS = st.one_of(
    st.builds(Helix, st.floats(0.1, 1e3), _FINITE, st.floats(1.0, 1e4), _FINITE),
    st.builds(Circle, st.floats(0.1, 1e3), st.floats(-1e4, -1.0), _FINITE),
    st.builds(Line, st.tuples(_FINITE, _FINITE, _FINITE), st.tuples(st.floats(0.5, 5.0), _FINITE, st.just(0.0))),
)


@settings(max_examples=40, deadline=None)
@given(_PATHS, st.tuples(_FINITE, _FINITE, st.floats(-50.0, 50.0)), st.floats(-1e5, 1e5))
def test_a_path_searched_as_lanes_gives_the_gamma_searched_one_at_a_time(path, point, reference) -> None:
    """The helix, circle and line take every sample's gamma at once (vehicles.nearest._points); the start each
    gives is the one of the same path evaluated gamma by gamma, to the bit."""
    assert path.lanes is True
    alone = nearest_gamma(_Alone(path), point, reference)  # type: ignore[arg-type]
    assert nearest_gamma(path, point, reference) == alone


def test_a_path_that_takes_lanes_is_sampled_all_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """The search's samples of a helix come from one evaluate_floats call on an array (else the test above would
    hold of a search that fell back to one gamma at a time)."""
    import vehicles.nearest

    shapes: list[tuple[int, ...]] = []
    inner = Helix.evaluate_floats

    def counted(self: Helix, gamma: float) -> tuple[tuple[float, ...], ...]:
        shapes.append(np.shape(gamma))
        return inner(self, gamma)

    monkeypatch.setattr(Helix, "evaluate_floats", counted)
    vehicles.nearest._points(Helix(20.0, 0.05, 400.0, 0.0), np.linspace(0.0, 400.0, 2001))
    assert shapes == [(2001,)]

"""A current the vehicles cannot make their way against: the speed through the water a path asks (its velocity less
the current's there) above a vehicle's top speed is warned of by `cpf validate` and `cpf run`, as a path faster than
the top speed is (supervisor.config.authority_checks).

    1 ----> 2 ----> 3     three lines 20 m apart at 1 m/s along x; the current along -x (a head current)
"""

from __future__ import annotations

import re

from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_checks import scenario_warnings
from tests.conftest import CONFIGS
from tests.lines_fleet import lines_fleet

PAPER = (CONFIGS / "paper.toml").read_text()
LINES = lines_fleet("head_current", "remus100_neutral")


def _speed_warnings(text: str, *sets: str) -> list[str]:
    return [w for w in scenario_warnings(parse_scenario(text, "s.toml", list(sets))) if "top speed" in w]


def _needed(warning: str) -> float:
    found = re.search(r"needs up to ([0-9.]+) m/s through the water", warning)
    assert found is not None, warning
    return float(found.group(1))


def test_a_head_current_on_lines_asks_three_metres_a_second_through_the_water():
    """1 m/s along the path against 2 m/s of current: 3 m/s through the water, above the 2.5 m/s top speed (the
    fleet crawled at 0.47 v_r unsaid)."""
    said = _speed_warnings(LINES, "environment.current=[-2.0,0.0,0.0]")
    assert [w.split(" needs")[0] for w in said] == [f"environment.current: vehicle {i}" for i in (1, 2, 3)]
    assert [_needed(w) for w in said] == [3.0, 3.0, 3.0]
    assert "above its top speed of 2.5 m/s" in said[0] and "current of [-2, 0, 0] m/s" in said[0], said[0]
    assert said[0].endswith("got [-2.0, 0.0, 0.0]"), said[0]


def test_a_current_faster_than_the_vehicles_on_the_paper_helices_is_warned_of_once_per_vehicle():
    """3 m/s across helices flown at 0.24-0.40 m/s: each vehicle needs ~3.3 m/s at the point of its lap where it
    heads into the current (the run ended 243 m outside the tube, surge at its limit, unsaid)."""
    said = _speed_warnings(PAPER, "environment.current=[3.0,0.0,0.0]")
    assert [w.split(" needs")[0] for w in said] == [f"environment.current: vehicle {i}" for i in (1, 2, 3)]
    for warning, radius in zip(said, (20.0, 15.0, 25.0), strict=True):
        along = 2 * 3.141592653589793 * radius / 400.0  # m/s on the helix (its climb of 0.05 m/s adds < 0.001)
        assert 3.0 + 0.97 * along < _needed(warning) <= 3.0 + along + 0.001, warning
        assert "top speed of 2.5 m/s" in warning and "[3, 0, 0]" in warning


def test_the_paper_scenario_and_a_half_metre_current_are_not_warned_of():
    assert _speed_warnings(PAPER) == []
    assert _speed_warnings(PAPER, "environment.current=[0.5,0.0,0.0]") == []
    assert _speed_warnings(LINES, "environment.current=[-0.5,0.0,0.0]") == []


def test_a_following_current_makes_a_path_faster_than_the_top_speed_flyable():
    """3 m/s along the lines with 2 m/s of current behind: 1 m/s through the water."""
    assert _speed_warnings(LINES, "coordination.v_r=3.0") != []
    assert _speed_warnings(LINES, "coordination.v_r=3.0", "environment.current=[2.0,0.0,0.0]") == []

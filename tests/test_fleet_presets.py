"""Vehicle presets to their sources, and mixed fleets: a preset and overrides per [[vehicles]] entry.

[vehicle] preset = P, overrides = O          (the fleet)
[[vehicles]] preset = Q?, overrides = O_i    (one vehicle: Q or P, then O, then O_i)
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from supervisor.config.derived import tube_radius
from supervisor.config.explain import what_would_run
from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.presets_table import top_speed
from supervisor.config.scenario import parse_scenario
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS, shortened
from tests.lines_fleet import lines_fleet
from vehicles.actuators import Actuators, remus100
from vehicles.agent import step
from vehicles.params import GRAVITY, PRESETS, VehicleParams, without_lift

PAPER = (CONFIGS / "paper.toml").read_text()


def _with(old: str, new: str, text: str = PAPER) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _error(text: str) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "mixed.toml")
    line = info.value.errors[0]
    assert "\n" not in line
    return line


SECOND = "id = 2\nposition = [5.0, 0.0, 0.0]\n"


def test_remus100_has_prestero_drag_and_its_published_top_speed():
    p = PRESETS["remus100"]
    assert p.quadratic_damping == (1.62, 131.0, 131.0)  # X_u|u|, Z_w|w| (Prestero 2001)
    assert p.angular_quadratic_damping == (0.0, 188.0, 94.0)  # M_q|q|, N_r|r| (Prestero 2001)
    assert p.buoyancy - p.weight == pytest.approx(3.3)  # B = W + 0.75 lbf (Hall and Anstee)
    assert top_speed(p) == pytest.approx(2.5)  # Fossen's remus100: 2.5 m/s


def test_remus100_neutral_is_remus100_trimmed_to_zero_net_buoyancy_without_lift():
    neutral, buoyant = PRESETS["remus100_neutral"], PRESETS["remus100"]
    assert neutral.buoyancy == neutral.weight
    assert dataclasses.replace(neutral, buoyancy=buoyant.buoyancy) == without_lift(buoyant)  # the paper's model


def test_remus100_legacy_keeps_the_old_numbers_to_the_bit():
    weight = 31.03 * GRAVITY
    old = VehicleParams(
        mass=(31.03 + 0.839, 31.03 + 29.44, 31.03 + 29.44), inertia=(0.112 + 0.0336, 4.028 + 3.426, 4.028 + 3.426),
        linear_damping=(31.87 / 20.0, 60.47 / 20.0, 60.47 / 20.0), quadratic_damping=(6.11, 131.0, 131.0),
        angular_linear_damping=(0.56, 7.454 / 5.0, 7.454 / 5.0), angular_quadratic_damping=(0.0, 9.4, 9.4),
        weight=weight, buoyancy=weight + 3.3, center_of_buoyancy=(0.0, 0.0, 0.0196), max_surge_force=60.0,
        max_torque=20.0,
    )  # fmt: skip
    assert PRESETS["remus100_legacy"] == old


def test_a_vehicle_entry_takes_its_own_preset_and_overrides_after_the_fleets():
    text = _with("[path_following]", "[vehicle.overrides]\nmax_torque = 15.0\n\n[path_following]")
    text = _with(SECOND, SECOND + 'preset = "remus100"\noverrides = { max_surge_force = 10.0 }\n', text)
    sc = parse_scenario(text, "mixed.toml")
    first, second = vehicle_config(sc, 1).params, vehicle_config(sc, 2).params
    assert first == dataclasses.replace(PRESETS["remus100_neutral"], max_torque=15.0)  # [vehicle] only
    assert second == dataclasses.replace(PRESETS["remus100"], max_torque=15.0, max_surge_force=10.0)


def test_an_unknown_preset_on_one_vehicle_names_that_entry():
    text = _with(SECOND, SECOND + 'preset = "sirene"\n')
    assert _error(text) == (
        "mixed.toml: vehicles[1].preset: unknown preset, expected one of "
        "['remus100', 'remus100_legacy', 'remus100_neutral'], got 'sirene'"
    )


def test_a_vehicle_override_is_checked_against_its_preset():
    text = _with(SECOND, SECOND + "overrides = { mass = [3.0, 3.0] }\n")  # one number (the rigid body's) or 3
    error = _error(text)
    assert error.startswith("mixed.toml: vehicles[1].overrides.mass: must be") and error.endswith("got [3.0, 3.0]")
    text = _with(SECOND, SECOND + "overrides = { wings = 2.0 }\n")
    assert _error(text).startswith("mixed.toml: vehicles[1].overrides.wings: unknown vehicle parameter, expected")


def test_the_paper_scenarios_fly_the_neutral_vehicle():
    for name in ("paper.toml", "paper_acoustic.toml"):
        sc = parse_scenario((CONFIGS / name).read_text(), name)
        assert sc.vehicle.preset == "remus100_neutral"


# A mixed fleet on fins (the researcher's hetero_fins): vehicle 2 flies the neutral preset, whose inputs are ideal.
#   1 (remus100) -- 2 (remus100_neutral) -- 3 (remus100), three parallel lines 20 m apart at 1 m/s
HETERO = lines_fleet("hetero_fins", "remus100", off=3.0, presets={2: "remus100_neutral"})


def _fins(sc, vid: int) -> Actuators | None:
    return vehicle_config(sc, vid).actuators


def test_each_vehicle_of_a_mixed_fleet_gets_its_own_presets_actuators_and_auto_controller():
    sc = parse_scenario(HETERO, "hetero.toml")
    thrust = PRESETS["remus100"].max_surge_force
    assert _fins(sc, 1) == _fins(sc, 3) == remus100(thrust)
    assert _fins(sc, 2) is None  # remus100_neutral: the paper's ideal inputs (cpf presets)
    assert type(vehicle_config(sc, 1).controller).__name__ == "LineOfSight"
    assert type(vehicle_config(sc, 2).controller).__name__ == "Backstepping"  # auto: the nominal plant


def test_a_remus100_vehicle_in_a_neutral_fleet_gets_its_fins():
    text = _with('preset = "remus100"\n[graph]', 'preset = "remus100_neutral"\n[graph]', HETERO)
    text = _with('preset = "remus100_neutral"\npath', 'preset = "remus100"\npath', text)
    sc = parse_scenario(text, "reverse.toml")
    assert _fins(sc, 1) is None and _fins(sc, 3) is None
    assert _fins(sc, 2) == remus100(PRESETS["remus100"].max_surge_force)


def test_fleet_wide_actuators_given_explicitly_win_over_a_vehicles_preset():
    sc = parse_scenario(HETERO, "hetero.toml", ["vehicle.actuators=ideal"])
    assert [_fins(sc, vid) for vid in (1, 2, 3)] == [None, None, None]
    sc = parse_scenario(HETERO, "hetero.toml", ["vehicle.actuators=remus100"])
    assert _fins(sc, 2) == remus100(PRESETS["remus100_neutral"].max_surge_force)


def test_the_neutral_vehicle_of_a_mixed_fleet_stays_in_its_tube():
    """Alone (no messages: its coordination keeps v_r), 100 s; on the fleet's fins it flew loops 64 m outside."""
    sc = parse_scenario(shortened(HETERO, 100.0), "hetero.toml")
    cfg = vehicle_config(sc, 2)
    state, errors = initial_state(sc, cfg), []
    for _ in range(round(100.0 / sc.scenario.step)):
        state, tel = step(cfg, state, sc.scenario.step, [])
        errors.append(float(np.linalg.norm(tel.error)))
    after = errors[round(sc.report.transient / sc.scenario.step) :]
    assert max(after) < tube_radius(sc)


def test_validate_names_each_vehicles_actuators_in_a_mixed_fleet():
    text = what_would_run(parse_scenario(HETERO, "hetero.toml"))
    assert "vehicles 1, 3: line_of_sight" in text and "remus100's fins and propeller" in text
    assert "vehicle 2: backstepping" in text and "ideal inputs" in text

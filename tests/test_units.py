"""Units you cannot mistake (issue 30, item 3): a value that only makes sense in the other unit is a warning, the
gamma_dot axis says the paths' own unit of gamma, a mass override is one number as `cpf presets` shows it, and
`cpf presets NAME` prints every parameter of a preset."""

from __future__ import annotations

import dataclasses

import pytest

from supervisor.analysis.figures import fig_gamma_dot
from supervisor.analysis.rundata import RunData
from supervisor.cli import main
from supervisor.config.derived import gamma_unit, rate_label
from supervisor.config.plant_schema import TideSection
from supervisor.config.scenario import ScenarioError, parse_scenario
from supervisor.config.scenario_checks import scenario_warnings
from supervisor.config.scenario_schema import CirclePath, HelixPath, LawnmowerPath
from supervisor.config.vehicle_models import params_of
from tests.conftest import CONFIGS, run_meta
from vehicles.params import GRAVITY, PRESETS, VehicleParams

PAPER = (CONFIGS / "paper.toml").read_text()
LAWN = (CONFIGS / "examples" / "lawnmower_survey.toml").read_text()


def test_an_angle_in_the_other_unit_is_a_warning():
    text = LAWN.replace("legs = 5 }", "legs = 5, heading_rad = 90.0 }", 1)
    assert text != LAWN
    [warning] = [w for w in scenario_warnings(parse_scenario(text, "s.toml")) if "heading" in w]
    assert warning.startswith("vehicles[0].path.heading_rad: in rad") and "90 deg is 1.5708 rad" in warning
    tide = "[environment]\ntide = { amplitude = [0.1, 0.0, 0.0], period = 600.0, phase_rad = 45.0 }\n"
    assert any(w.startswith("environment.tide.phase_rad: in rad") for w in scenario_warnings(parse_scenario(
        PAPER + tide, "s.toml")))  # fmt: skip
    rad = scenario_warnings(parse_scenario(PAPER, "s.toml", ("vehicles.0.attitude_rpy_deg=[0.0, 0.0, 1.5708]",)))
    assert any(w.startswith("vehicles[0].attitude_rpy_deg: in deg, and these look like rad") for w in rad)
    assert scenario_warnings(parse_scenario(PAPER, "s.toml")) == []  # phase -2.356 rad, no attitude given


def test_every_angle_key_says_its_unit_and_the_old_names_are_still_read_and_said():
    """`phase` and `heading` (rad) became `phase_rad` and `heading_rad`: a file with the old names gives the same
    scenario, and a warning for each; both names in one table are one key given twice, an error."""
    for table in (HelixPath, CirclePath, LawnmowerPath, TideSection):
        angles = [name for name in table.model_fields if "phase" in name or "heading" in name or "attitude" in name]
        assert angles and all(name.endswith(("_rad", "_deg")) for name in angles), (table.__name__, angles)
    old = PAPER.replace("phase_rad = ", "phase = ") + "[environment]\ntide = { amplitude = [0.1, 0.0, 0.0], "
    new = PAPER + "[environment]\ntide = { amplitude = [0.1, 0.0, 0.0], "
    old, new = old + "period = 600.0, phase = 0.5 }\n", new + "period = 600.0, phase_rad = 0.5 }\n"
    assert old.count("phase = ") == 4
    assert parse_scenario(old, "s.toml").model_dump() == parse_scenario(new, "s.toml").model_dump()
    said = scenario_warnings(parse_scenario(old, "s.toml"))
    assert said == [
        *(f"vehicles[{i}].path.phase: read as phase_rad (rad), its name now; write phase_rad" for i in range(3)),
        "environment.tide.phase: read as phase_rad (rad), its name now; write phase_rad",
    ]
    assert scenario_warnings(parse_scenario(new, "s.toml")) == []
    lawn = parse_scenario(LAWN.replace("legs = 5 }", "legs = 5, heading = 0.5 }", 1), "s.toml")
    assert isinstance(lawn.vehicles[0].path, LawnmowerPath) and lawn.vehicles[0].path.heading_rad == 0.5
    assert scenario_warnings(lawn)[0].startswith("vehicles[0].path.heading: read as heading_rad (rad)")
    twice = PAPER.replace("phase_rad = -2.356194490192345 }", "phase_rad = -2.356194490192345, phase = 1.0 }", 1)
    with pytest.raises(ScenarioError, match=r"s.toml: vehicles\[0\]\.path.*phase is the old name of phase_rad: give "
                       r"phase_rad only"):  # fmt: skip
        parse_scenario(twice, "s.toml")


def test_a_mass_override_is_one_number_as_cpf_presets_shows_it():
    text = PAPER.replace('preset = "remus100_neutral"', 'preset = "remus100_neutral"\noverrides = { mass = 40.0 }')
    params = params_of(parse_scenario(text, "s.toml"), 1)
    base = PRESETS["remus100_neutral"]
    added = [m - base.weight / GRAVITY for m in base.mass]
    assert params.mass == pytest.approx([40.0 + a for a in added])  # the rigid body's, the added mass kept
    assert params.weight == pytest.approx(40.0 * GRAVITY)
    assert params.weight - params.buoyancy == pytest.approx(base.weight - base.buoyancy)  # its trim kept
    three = PAPER.replace(
        'preset = "remus100_neutral"', 'preset = "remus100_neutral"\noverrides = { mass = [50.0, 60.0, 70.0] }'
    )
    assert params_of(parse_scenario(three, "s.toml"), 1).mass == (50.0, 60.0, 70.0)  # M's diagonal as it stands


def test_cpf_presets_name_prints_every_parameter(capsys):
    assert main(["presets", "remus100"]) == 0
    out = capsys.readouterr().out
    for field in dataclasses.fields(VehicleParams):
        assert f"  {field.name} = " in out
    assert f"rigid-body mass {PRESETS['remus100'].weight / GRAVITY:g} kg" in out
    assert main(["presets", "unet_2400"]) == 0
    assert "  half_duplex = true" in capsys.readouterr().out
    assert main(["presets", "nope"]) == 2
    assert "no preset 'nope'" in capsys.readouterr().err


def test_the_gamma_dot_axis_says_the_paths_unit_of_gamma():
    line = {"type": "line", "start": [0.0, 0.0, 0.0], "velocity": [1.0, 0.0, 0.0]}
    helix = {"type": "helix", "radius": 10.0, "climb": 0.0, "period": 100.0}
    assert rate_label(gamma_unit([line, line])) == "m/s"
    assert rate_label(gamma_unit([helix])) == "1/s"
    assert rate_label(gamma_unit([{"type": "lawnmower", "scale": 2.0}])) == "(2 m)/s"
    assert rate_label(gamma_unit([line, helix])) == "unit of gamma per s"
    meta = run_meta(vehicles=(1, 2), scenario={"vehicles": [{"path": line}, {"path": line}]})
    axis = fig_gamma_dot(RunData(meta, {}, [], [])).axes[0].get_ylabel()
    assert axis == r"$\dot\gamma_i$ [m/s]"

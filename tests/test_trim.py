"""vehicles.trim, the pitch moment a steady line takes, against the physics and against the simulator: a vehicle
whose fins give less than its trim needs leaves its line whatever its controller does, and one just faster holds it;
`cpf validate` says which."""

from __future__ import annotations

import math

import pytest

from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_checks import scenario_warnings
from tests.conftest import CONFIGS
from tests.fly_a_line import fly_a_line, scenario_text
from vehicles.actuators import remus100
from vehicles.params import PRESETS
from vehicles.trim import pitch_moment
from vehicles.uncertainty import perturbed
from vehicles.vehicle_model import Remus100, Remus100Neutral

REMUS, MODEL = PRESETS["remus100"], Remus100()
FINS = remus100(REMUS.max_surge_force).fin_moment  # N m per (m/s)^2
HEAVY = {"seed": 3, "uncertainty": "{ mass = 0.2 }", "vehicle_id": 4}  # heave mass +20 %, surge -15 %: Munk term +59 %


def test_a_neutral_vehicle_without_lift_flies_level_with_no_moment():
    """B = W and no lift: the trim is at zero angle of attack, where neither the Munk nor the restoring moment acts."""
    assert pitch_moment(Remus100Neutral(), PRESETS["remus100_neutral"], 1.0) == pytest.approx(0.0, abs=1e-12)


def test_the_buoyant_remus_holds_its_depth_on_a_share_of_its_fins_that_falls_with_speed():
    """At 1 m/s the preset needs 0.94 N m of its fins' 1.46; u w is fixed by the net buoyancy, so the moment grows
    less than the fins' u^2 and the share falls."""
    moments = [pitch_moment(MODEL, REMUS, u) for u in (1.0, 1.5, 2.0)]
    assert None not in moments and moments[:2] == pytest.approx([-0.94, -1.41], abs=0.01)  # vehicles/trim.py's numbers
    shares = [abs(m) / (FINS * u * u) for m, u in zip(moments, (1.0, 1.5, 2.0), strict=True) if m is not None]
    assert shares[0] == pytest.approx(0.94 / 1.46, abs=0.01)
    assert shares == sorted(shares, reverse=True)


def _least_speed() -> float:
    plant = perturbed(REMUS, {"mass": 0.2}, 3, 4)
    for u in (1.0 + 0.01 * k for k in range(150)):
        moment = pitch_moment(MODEL, plant, u)
        if moment is not None and abs(moment) <= FINS * u * u:
            return u
    raise AssertionError("no trim the fins hold up to 2.5 m/s")


def test_below_the_trims_least_speed_the_vehicle_leaves_its_line_and_above_it_holds():
    """The heavier vehicle's trim needs more than its fins below 1.40 m/s. Flown by the default controller (with
    its disturbance observer), 10 % slower it sinks off its line; 10 % faster it holds it to 0.1 m."""
    least = _least_speed()
    assert least == pytest.approx(1.40, abs=0.01)
    slow = fly_a_line(0.9 * least, 300.0, **HEAVY)
    fast = fly_a_line(1.1 * least, 300.0, **HEAVY)
    assert min(slow[1500:]) > 5.0
    assert max(fast[1500:]) < 0.1


def test_validate_says_which_vehicle_its_fins_cannot_hold_and_from_what_speed_they_do():
    slow = scenario_warnings(parse_scenario(scenario_text(1.0, 10.0, **HEAVY), "heavy.toml"))  # type: ignore[arg-type]
    fast = scenario_warnings(parse_scenario(scenario_text(1.5, 10.0, **HEAVY), "heavy.toml"))  # type: ignore[arg-type]
    (warning,) = [w for w in slow if "pitch moment" in w]
    assert warning.startswith("coordination.v_r: vehicle 4 (its plant as drawn")
    assert "2.26 N m" in warning and "1.45 N m" in warning and "from 1.40 m/s, v_r 1.4;" in warning
    assert not [w for w in fast if "pitch moment" in w]


def test_the_slow_examples_kept_on_ideal_inputs_are_the_ones_validate_says_fins_cannot_fly():
    """circles.toml and the paper fly slower than a REMUS's fins hold them (their files say so: on fins circles ends
    10.6 m off); put on the fins, validate says it for them, and for inline5 at its 1 m/s it says nothing."""
    fins = ["vehicle.preset=remus100", "vehicle.actuators=remus100"]
    cases = (("examples/circles.toml", "(level)"), ("paper.toml", "(climbing"), ("inline5.toml", None))
    for name, slope in cases:
        path = CONFIGS / name
        warnings = [w for w in scenario_warnings(parse_scenario(path.read_text(), str(path), fins)) if "fins" in w]
        assert bool(warnings) == (slope is not None), name
        assert all(slope is not None and slope in w for w in warnings), name


def test_a_descending_path_is_trimmed_descending():
    """The helix ring descends (climb < 0) at 0.42 m/s: its trim needs 1.05 N m where a climb as steep would
    need 0.51; the check must take the path's own sign, not v_r's."""
    path = CONFIGS / "examples" / "helix_ring_30s.toml"
    fins = ["vehicle.preset=remus100", "vehicle.actuators=remus100"]
    first = next(w for w in scenario_warnings(parse_scenario(path.read_text(), str(path), fins)) if "fins" in w)
    assert "vehicle 1 needs a pitch moment of 1.05 N m to fly its path at 0.42 m/s (descending 3 deg)" in first
    assert pitch_moment(MODEL, REMUS, 0.42, math.radians(3.0)) != pytest.approx(
        pitch_moment(MODEL, REMUS, 0.42, math.radians(-3.0)), abs=0.1
    )


def test_v_r_zero_is_warned_of_as_a_path_of_no_speed_is():
    """A vehicle asked to stop on its path (v_r = 0) gets the warning a line of 1e-6 m/s gets; it was skipped as a
    point of no speed, and the run left the tube by 9 m unsaid (a new user)."""
    text = (CONFIGS / "ring10_1hz.toml").read_text()  # REMUS 100s, not trimmed neutral, on lines
    warnings = [w for w in scenario_warnings(parse_scenario(text, "r.toml", ["coordination.v_r=0"])) if "trim" in w]
    assert len(warnings) == 10, warnings
    assert warnings[0].startswith("coordination.v_r: vehicle 1 finds no trim") and warnings[0].endswith("got 0")


def test_a_path_faster_than_the_vehicles_top_speed_is_warned_of():
    """~13 m/s asked of a REMUS 100 (top speed 2.5 m/s) passed validate unsaid (a new user): the paper's helices at
    v_r 10 ask 3.2 and 4.0 m/s of vehicles 1 and 3 (radius 20 and 25 m), 2.4 m/s of vehicle 2 (15 m)."""
    text = (CONFIGS / "paper.toml").read_text()
    fast = [w for w in scenario_warnings(parse_scenario(text, "p.toml", ["coordination.v_r=10"])) if "top speed" in w]
    assert [w.split(" is asked")[0] for w in fast] == ["coordination.v_r: vehicle 1", "coordination.v_r: vehicle 3"]
    assert "above its top speed of 2.5 m/s" in fast[0], fast
    assert not [w for w in scenario_warnings(parse_scenario(text, "p.toml")) if "top speed" in w]

"""Model mismatch (vehicles.uncertainty, [vehicle] uncertainty) and the [environment] keys: the draw is
reproducible and within bounds, a perturbed plant stays in the tube (the paper's Lemma 1), bad values give one-line
errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.plant import plant_of
from supervisor.config.scenario import parse_scenario
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS
from vehicles.agent import step
from vehicles.params import LIFT_FIELDS, PRESETS
from vehicles.uncertainty import GROUPS, factors, perturbed

REMUS = PRESETS["remus100"]
PAPER = (CONFIGS / "paper.toml").read_text()


def scenario(*sets: str):
    return parse_scenario(PAPER, "paper.toml", overrides=list(sets))


def ratios(plant, nominal) -> list[float]:
    """plant / nominal for every coefficient the draw touches (net weight W - B as one)."""
    out = []
    for name in (g for g in GROUPS if g not in ("buoyancy", "net_weight", "lift")):
        out += [a / b for a, b in zip(getattr(plant, name), getattr(nominal, name), strict=True) if b != 0]
    out += [getattr(plant, name) / getattr(nominal, name) for name in LIFT_FIELDS]
    out.append(plant.buoyancy / nominal.buoyancy)
    out.append((plant.weight - plant.buoyancy) / (nominal.weight - nominal.buoyancy))
    return out


@pytest.mark.parametrize("spread", [0.05, 0.2, 0.9])
def test_every_coefficient_is_drawn_within_the_spread_and_not_all_the_same(spread):
    r = ratios(perturbed(REMUS, dict.fromkeys(GROUPS, spread), 3, 2), REMUS)
    assert all(1 - spread <= x <= 1 + spread for x in r)
    assert len(set(r)) == len(r)  # one draw per coefficient
    assert max(abs(x - 1) for x in r) > spread / 2  # and they use the range
    assert perturbed(REMUS, {}, 3, 2) == REMUS


def test_the_draw_depends_on_seed_and_vehicle_only_and_per_group_spreads_keep_the_others_draws():
    spread = dict.fromkeys(GROUPS, 0.2)
    assert perturbed(REMUS, spread, 7, 1) == perturbed(REMUS, spread, 7, 1)
    assert perturbed(REMUS, spread, 7, 1) != perturbed(REMUS, spread, 7, 2)
    assert perturbed(REMUS, spread, 7, 1) != perturbed(REMUS, spread, 8, 1)
    only_mass = perturbed(REMUS, {"mass": 0.2}, 7, 1)
    assert only_mass.mass == perturbed(REMUS, spread, 7, 1).mass
    assert dataclasses.replace(only_mass, mass=REMUS.mass) == REMUS


def test_the_scenario_draws_one_plant_per_vehicle_and_the_controller_keeps_the_nominal_model():
    sc = scenario("vehicle.uncertainty=0.2", "scenario.seed=5")
    configs = [vehicle_config(sc, i) for i in sc.vehicle_ids]
    nominal = dataclasses.replace(PRESETS[sc.vehicle.preset], **sc.vehicle.overrides)
    assert all(c.params == nominal for c in configs)
    plants = [c.plant for c in configs]
    assert all(p is not None and p != nominal for p in plants)
    assert len({p for p in plants}) == 3
    assert plants[1] == plant_of(sc, 2)  # the same draw wherever it is made
    assert vehicle_config(scenario(), 1).plant is None  # off by default
    table = scenario("vehicle.uncertainty={quadratic_damping = 0.3}")
    only = plant_of(table, 1)
    assert only is not None and only.mass == REMUS.mass and only.quadratic_damping != REMUS.quadratic_damping


def errors(seconds: float, *sets: str) -> list[float]:
    """|p - p_d| after the transient of AUV 1 alone (no neighbours) on its paper path."""
    sc = scenario(*sets)
    cfg = vehicle_config(sc, 1)
    state = initial_state(sc, cfg)
    out = []
    for _ in range(round(seconds / sc.scenario.step)):
        state, tel = step(cfg, state, sc.scenario.step, [])
        if tel.t >= sc.report.transient:
            out.append(float(np.linalg.norm(tel.error)))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_perturbed_plant_converges_into_the_tube(seed):
    """The paper's Lemma 1 assumes a path-following controller that tolerates parametric uncertainty (Aguiar &
    Hespanha's adaptive switching supervisor, which `auto` chooses here): with +-30 % on every coefficient the error
    stays in the report's tube, |delta| + tube_margin = 1.2 m, within a few cm of |delta| (the nominal run stays at
    |delta| = 1 m). scripts/vehicle_robustness.py measures it to +-60 %."""
    nominal = errors(200.0)
    mismatched = errors(200.0, "vehicle.uncertainty=0.3", f"scenario.seed={seed}")
    assert max(mismatched) <= 1.2
    assert max(abs(e - 1.0) for e in mismatched) < 0.1
    assert max(abs(a - b) for a, b in zip(mismatched, nominal, strict=True)) > 1e-4  # it acts


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ("environment.current=[0.1, 0.2]", "paper.toml: environment.current: too few items, got [0.1, 0.2]"),
        ("environment.current=0.2", "paper.toml: environment.current: must be an array, got 0.2"),
        ("environment.current=[9.0, 0.0, 0.0]", "environment.current[0]: must be less than or equal to 5, got 9.0"),
        ("environment.tide={amplitude = [0.1, 0, 0], period = 0}", "environment.tide.period: must be greater than 0"),
        ("environment.tide={amplitude = [0.1, 0, 0], period = -5.0}", "environment.tide.period: must be greater"),
        ("environment.tide={period = 100.0}", "environment.tide.amplitude: missing required field"),
        ("environment.shear=[0.1, 0.0, 0.0]", "environment.shear: must have at most 2 items, got [0.1, 0.0, 0.0]"),
        ("environment.current_known=1", "environment.current_known: must be a valid boolean, got 1"),
        ("environment.wind=1", "environment.wind: unknown key"),
        ("environment.shear=[0.01, 0.0]", "environment.shear: a planar scenario (scenario.dimension = 2) has"),
        ("vehicle.uncertainty=-0.1", "vehicle.uncertainty: must be greater than or equal to 0"),
        ("vehicle.uncertainty=1.5", "vehicle.uncertainty: must be less than or equal to 0.9"),
        ("vehicle.uncertainty={drag = 0.1}", "vehicle.uncertainty.drag: unknown key"),
        ("vehicle.uncertainty={mass = 2.0}", "vehicle.uncertainty.mass: must be less than or equal to 0.9, got 2.0"),
    ],
)
def test_bad_environment_and_uncertainty_values_give_one_line_errors(setting, message):
    flat = [f"vehicles.{i}.path.climb=0.0" for i in range(3)]
    planar = ["scenario.dimension=2", *flat] if "dimension = 2" in message else []
    with pytest.raises(ScenarioError) as info:
        scenario(*planar, setting)
    text = str(info.value)
    if planar:  # paper.toml's vehicles are off the plane too: the planar rule's error is one of the lines
        text = next(line for line in text.splitlines() if "environment" in line)
    assert message in text, text
    assert "\n" not in text


def test_cpf_info_lines_name_the_current_and_each_vehicles_drawn_plant():
    from supervisor.config.plant import describe_plant

    assert describe_plant(scenario()) == []
    sc = scenario("vehicle.uncertainty={mass = 0.2}", "environment.current=[0.1, 0.0, 0.0]")
    lines = describe_plant(sc)
    assert lines[0] == "current    [0.1, 0.0, 0.0] m/s; unknown to the controllers"
    plant = plant_of(sc, 2)
    assert plant is not None
    shown = "/".join(f"{100 * (a / b - 1):+.1f}" for a, b in zip(plant.mass, REMUS.mass, strict=True))
    assert lines[2] == f"plant 2    mass {shown} %"
    assert len(lines) == 4


def test_cpf_info_lines_name_every_group_drawn_the_lift_too():
    """The lift's four coefficients are fields of their own, not one tuple: cpf info of any run with `uncertainty =
    0.1` (the lift included) ended in an AttributeError (found by a new user)."""
    from supervisor.config.plant import describe_plant

    sc = scenario("vehicle.uncertainty=0.1", "vehicle.preset=remus100")  # a preset with lift
    plant = plant_of(sc, 2)
    assert plant is not None and all(getattr(REMUS, f) for f in LIFT_FIELDS)
    lift = "/".join(f"{100 * (getattr(plant, f) / getattr(REMUS, f) - 1):+.1f}" for f in LIFT_FIELDS)
    assert describe_plant(sc)[1].endswith(f", lift {lift} %") and lift.count("/") == 3


@pytest.mark.parametrize("seed", [0, 3])
def test_at_60_percent_mismatch_the_supervisor_keeps_the_tube_where_backstepping_alone_does_not(seed):
    """Issue 24's acceptance on the seeds where backstepping alone left the tube (scripts/vehicle_robustness.py
    runs seeds 0-9): with every coefficient within +-60 %, the default controller (`auto`: the adaptive switching
    supervisor) keeps the paper fleet's path error inside the tube (1.2 m) and its coordination error < 0.05 over
    the last 50 s; backstepping with the damping fed forward also coordinates but leaves the tube by 5-8 mm
    (measured 1.2065 and 1.2078), and cancelling the damping at the measured velocity (the controller before issue
    24) is anti-damping: the fleet does not coordinate (measured 1.54, path 3.4 m at seed 0)."""
    from supervisor.tools.stability_check import simulate

    text = (CONFIGS / "paper.toml").read_text()
    mismatch = ["vehicle.uncertainty=0.6", f"scenario.seed={seed}"]
    supervised = simulate(parse_scenario(text, "paper.toml", mismatch))
    alone = ["path_following.controller=backstepping"]
    fed = simulate(parse_scenario(text, "paper.toml", [*mismatch, *alone]))
    assert supervised.last < 0.05 and supervised.path_error < 1.2, supervised
    assert fed.last < 0.05 and 1.2 < fed.path_error < 1.21, fed
    if seed == 0:
        cancelled = simulate(parse_scenario(text, "paper.toml", [*mismatch, *alone, "path_following.damping=cancel"]))
        assert cancelled.last > 0.5 and cancelled.path_error > 2.0, cancelled


def test_the_lift_draws_come_after_the_others_so_older_plants_are_drawn_the_same():
    """The lift group was added after plants had been drawn and recorded: every other group's factors are the first
    27 numbers of the vehicle's stream, as they were, and the lift's the next four."""
    rng = np.random.default_rng([11, 3, 0x706C616E74])
    stream = rng.uniform(-1.0, 1.0, size=31)
    before = np.random.default_rng([11, 3, 0x706C616E74]).uniform(-1.0, 1.0, size=27)  # the draw without the lift
    np.testing.assert_array_equal(stream[:27], before)
    e = factors(11, 3)
    for i, group in enumerate(GROUPS[:-1]):
        size = 1 if group in ("buoyancy", "net_weight") else 3
        assert e[group] == tuple(stream[3 * i : 3 * i + size])
    assert e["lift"] == tuple(stream[27:31])

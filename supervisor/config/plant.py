"""From a validated Scenario to the plant each vehicle swims as: its ocean current and its drawn parameters.

Both engines (and a vehicle process, and re-simulation) build them here from the scenario alone, so a vehicle has the
same plant wherever and whenever it runs (vehicles.uncertainty seeds its draw by scenario seed and vehicle id).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from supervisor.config.plant_schema import ActuatorTable, UncertaintyTable
from supervisor.config.scenario_schema import Scenario
from supervisor.config.vehicle_models import params_of, preset_of
from vehicles.actuators import Actuators, remus100
from vehicles.current import Current
from vehicles.params import LIFT_FIELDS, VehicleParams
from vehicles.uncertainty import GROUPS, perturbed


def current_of(scenario: Scenario) -> Current | None:
    """The scenario's current; None in still water (the closed loop then runs as it always did)."""
    env = scenario.environment
    if env.still:
        return None
    tide = env.tide
    if tide is None:
        return Current(env.current, shear=env.shear, shear_origin=env.shear_origin)
    return Current(env.current, tide.amplitude, tide.period, tide.phase_rad, env.shear, env.shear_origin)


def spreads(scenario: Scenario) -> dict[str, float]:
    """The relative spread of each group of coefficients ({} when the plant is the nominal model)."""
    given = scenario.vehicle.uncertainty
    table = given.model_dump() if isinstance(given, UncertaintyTable) else dict.fromkeys(GROUPS, given)
    return {group: spread for group, spread in table.items() if spread > 0}


# The actuators a preset comes with: the REMUS 100 as at sea has its fins and propeller (and the lift that lets them
# steer it: vehicles.params); the paper's model keeps its idealised inputs.
PRESET_ACTUATORS = {"remus100": "remus100"}


def actuation(scenario: Scenario, vehicle_id: int) -> str | ActuatorTable:
    """vehicle_id's actuators: [vehicle] actuators as given (for the whole fleet), or by default ("preset") its own
    preset's (its [[vehicles]] preset, else [vehicle] preset: a mixed fleet); "ideal" for another vehicle model."""
    given = scenario.vehicle.actuators
    if given != "preset":
        return given
    if scenario.vehicle.model is not None:
        return "ideal"
    return PRESET_ACTUATORS.get(preset_of(scenario, vehicle_id), "ideal")


def actuators_of(scenario: Scenario, vehicle_id: int, params: VehicleParams) -> Actuators | None:
    """vehicle_id's actuators (actuation) for its nominal parameters (its propeller's thrust is their
    max_surge_force); None: ideal."""
    given = actuation(scenario, vehicle_id)
    if given == "ideal":
        return None
    if given == "remus100":
        return remus100(params.max_surge_force)
    assert isinstance(given, ActuatorTable)
    rate = None if given.max_rate_deg is None else math.radians(given.max_rate_deg)
    return Actuators(
        given.fin_lift, math.radians(given.max_deflection_deg), given.fin_time_constant,
        given.thruster_time_constant, params.max_surge_force, rate,
    )  # fmt: skip


def plant_of(scenario: Scenario, vehicle_id: int, seed: int | None = None) -> VehicleParams | None:
    """The plant's parameters of vehicle_id, drawn around the scenario's with the run's seed (None: the
    scenario's); None when there is no mismatch."""
    spread = spreads(scenario)
    if not spread:
        return None
    run_seed = scenario.scenario.seed if seed is None else seed
    return perturbed(params_of(scenario, vehicle_id), spread, run_seed, vehicle_id)


def planar_current_errors(sc: Scenario) -> Iterator[str]:
    """A planar run (dimension 2) has no vertical axis: a vertical current or a shear in depth could not act."""
    if sc.scenario.dimension != 2:
        return
    env = sc.environment
    if env.current[2] != 0:
        yield f"environment.current: a planar scenario (scenario.dimension = 2) has no vz, got {list(env.current)}"
    if env.tide is not None and env.tide.amplitude[2] != 0:
        yield f"environment.tide.amplitude: a planar scenario has no vertical tide, got {list(env.tide.amplitude)}"
    if any(env.shear):
        shear = list(env.shear)
        yield f"environment.shear: a planar scenario (scenario.dimension = 2) has no depth to shear over, got {shear}"


def describe_plant(sc: Scenario, seed: int | None = None) -> list[str]:
    """Lines for cpf info: the current, and each vehicle's drawn plant as % off the nominal coefficients (what
    the run's analysis needs besides the log: the current at a vehicle is current_of(sc).velocity(t, z)); seed: the
    run's (None: the scenario's)."""
    env, lines = sc.environment, []
    if not env.still:
        tide = env.tide
        tidal = f" + tide {list(tide.amplitude)} m/s, period {tide.period:g} s" if tide is not None else ""
        shear = f" + shear {list(env.shear)} 1/s from z = {env.shear_origin:g} m" if any(env.shear) else ""
        known = "known to" if env.current_known else "unknown to"
        lines.append(f"current    {list(env.current)} m/s{tidal}{shear}; {known} the controllers")
    for vid in sc.vehicle_ids:
        plant = plant_of(sc, vid, seed)
        if plant is not None:
            nominal = params_of(sc, vid)  # its own preset's, in a mixed fleet
            lines.append(f"plant {vid:<4} " + ", ".join(_off(g, plant, nominal) for g in spreads(sc)))
    return lines


def _off(group: str, plant: VehicleParams, nominal: VehicleParams) -> str:
    """'mass +3.1/-8.0/+12.0 %': a group's coefficients as % off nominal."""
    if group == "net_weight":
        pairs = [(plant.weight - plant.buoyancy, nominal.weight - nominal.buoyancy)]
    elif group == "buoyancy":
        pairs = [(plant.buoyancy, nominal.buoyancy)]
    elif group == "lift":  # four fields of their own (vehicles.uncertainty), not one tuple
        pairs = [(getattr(plant, name), getattr(nominal, name)) for name in LIFT_FIELDS]
    else:
        pairs = list(zip(getattr(plant, group), getattr(nominal, group), strict=True))
    return f"{group} " + "/".join(f"{100 * (a / b - 1):+.1f}" if b else "0" for a, b in pairs) + " %"

"""From a validated Scenario to the plant each vehicle swims as: its ocean current and its drawn parameters.

Both engines (and a vehicle process, and re-simulation) build them here from the scenario alone, so a vehicle has the
same plant wherever and whenever it runs (vehicles.uncertainty seeds its draw by scenario seed and vehicle id).
"""

from __future__ import annotations

from collections.abc import Iterator

from supervisor.config.plant_schema import UncertaintyTable
from supervisor.config.scenario_schema import Scenario
from vehicles.current import Current
from vehicles.params import VehicleParams
from vehicles.uncertainty import GROUPS, perturbed


def current_of(scenario: Scenario) -> Current | None:
    """The scenario's current; None in still water (the closed loop then runs as it always did)."""
    env = scenario.environment
    if env.still:
        return None
    tide = env.tide
    if tide is None:
        return Current(env.current, shear=env.shear, shear_origin=env.shear_origin)
    return Current(env.current, tide.amplitude, tide.period, tide.phase, env.shear, env.shear_origin)


def spreads(scenario: Scenario) -> dict[str, float]:
    """The relative spread of each group of coefficients ({} when the plant is the nominal model)."""
    given = scenario.vehicle.uncertainty
    table = given.model_dump() if isinstance(given, UncertaintyTable) else dict.fromkeys(GROUPS, given)
    return {group: spread for group, spread in table.items() if spread > 0}


def plant_of(scenario: Scenario, vehicle_id: int) -> VehicleParams | None:
    """The plant's parameters of vehicle_id, drawn around the scenario's; None when there is no mismatch."""
    spread = spreads(scenario)
    if not spread:
        return None
    return perturbed(scenario.vehicle_params(), spread, scenario.scenario.seed, vehicle_id)


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

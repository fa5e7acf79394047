"""Each vehicle's model and limits in a (possibly mixed) fleet: its preset and overrides, its top speed.

A [[vehicles]] entry may name its own preset and overrides; what it leaves out comes from [vehicle]. The overrides
compose: the preset's values, then [vehicle] overrides (fleet-wide changes), then the entry's own.
"""

from __future__ import annotations

from supervisor.config.presets_table import top_speed
from supervisor.config.scenario_schema import Scenario, VehicleSection
from vehicles.params import VehicleParams, preset


def _entry(scenario: Scenario, vehicle_id: int) -> VehicleSection:
    return next(v for v in scenario.vehicles if v.id == vehicle_id)


def preset_of(scenario: Scenario, vehicle_id: int) -> str:
    """The preset vehicle_id runs: its entry's, or [vehicle] preset."""
    return _entry(scenario, vehicle_id).preset or scenario.vehicle.preset


def params_of(scenario: Scenario, vehicle_id: int) -> VehicleParams:
    """vehicle_id's parameters: its preset with [vehicle] overrides and then its own applied."""
    entry = _entry(scenario, vehicle_id)
    return preset(preset_of(scenario, vehicle_id), **{**scenario.vehicle.overrides, **entry.overrides})


def top_speed_of(scenario: Scenario, vehicle_id: int) -> float | None:
    """The speed [m/s] vehicle_id is held to along its path ([saturation] top_speed), or None: unbounded."""
    speed = scenario.saturation.top_speed
    if speed == "preset":
        return top_speed(params_of(scenario, vehicle_id))
    return speed

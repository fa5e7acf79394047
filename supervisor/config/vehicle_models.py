"""Each vehicle's model and limits in a (possibly mixed) fleet: its vehicle model, its parameters, its top speed.

A vehicle model (vehicles.vehicle_model) is an extension of the group `cpf.vehicles`: the presets are its built-ins,
found by name and built with their parameters as options, the same way as a model named by [vehicle] model. A
[[vehicles]] entry may name its own preset and overrides; what it leaves out comes from [vehicle]. The overrides
compose: the preset's values, then [vehicle] overrides (fleet-wide changes), then the entry's own. A [vehicle] model
takes its options from [vehicle] model_options, for the whole fleet.
"""

from __future__ import annotations

from typing import Any

from supervisor.config.extensions import extension
from supervisor.config.presets_table import top_speed
from supervisor.config.scenario_schema import Scenario, VehicleSection
from vehicles.params import GRAVITY, PRESETS, VehicleParams
from vehicles.vehicle_model import VehicleModel


def _entry(scenario: Scenario, vehicle_id: int) -> VehicleSection:
    return next(v for v in scenario.vehicles if v.id == vehicle_id)


def preset_of(scenario: Scenario, vehicle_id: int) -> str:
    """The preset vehicle_id runs: its entry's, or [vehicle] preset."""
    return _entry(scenario, vehicle_id).preset or scenario.vehicle.preset


def model_name_of(scenario: Scenario, vehicle_id: int) -> str:
    """The vehicle model vehicle_id runs: [vehicle] model, or its preset."""
    return scenario.vehicle.model or preset_of(scenario, vehicle_id)


def model_options_of(scenario: Scenario, vehicle_id: int) -> dict[str, Any]:
    """Its options: [vehicle] model_options, or a preset's overrides ([vehicle]'s, then its entry's)."""
    if scenario.vehicle.model is not None:
        return dict(scenario.vehicle.model_options)
    given = {**scenario.vehicle.overrides, **_entry(scenario, vehicle_id).overrides}
    return as_read(preset_of(scenario, vehicle_id), given)


def as_read(preset: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """Overrides as users read them: `mass = 40.0` is the rigid body's mass (what `cpf presets` shows), the diagonal
    of M then that plus the preset's added mass on each axis, its weight m g, and its buoyancy moved with the weight
    so that the preset's trim (W - B) holds; 3 numbers are M's diagonal as they stand."""
    mass = overrides.get("mass")
    if not isinstance(mass, int | float) or preset not in PRESETS:
        return overrides
    base = PRESETS[preset]
    rigid = base.weight / GRAVITY
    weight = overrides.get("weight", mass * GRAVITY)
    return {
        "buoyancy": base.buoyancy + (weight - base.weight),
        **overrides,
        "mass": tuple(mass + (axis - rigid) for axis in base.mass),
        "weight": weight,
    }


def vehicle_of(scenario: Scenario, vehicle_id: int) -> VehicleModel:
    """vehicle_id's vehicle model, built with its options and the scenario's dimension (someone else's guarded)."""
    context = {"dimension": scenario.scenario.dimension}
    model: VehicleModel = extension(
        "model", model_name_of(scenario, vehicle_id), model_options_of(scenario, vehicle_id), context
    )
    return model


def params_of(scenario: Scenario, vehicle_id: int) -> VehicleParams:
    """vehicle_id's parameters: its vehicle model's (a preset's with [vehicle] overrides and then its own applied)."""
    return vehicle_of(scenario, vehicle_id).parameters()


def top_speed_of(scenario: Scenario, vehicle_id: int) -> float | None:
    """The speed [m/s] vehicle_id is held to along its path ([saturation] top_speed), or None: unbounded."""
    speed = scenario.saturation.top_speed
    if speed == "preset":
        return top_speed(params_of(scenario, vehicle_id))
    return speed

"""Each vehicle parameter's range, in one place: what [vehicle] overrides may set and what a vehicle model's
parameters() may give (supervisor.config.scenario_checks, extension_checks)."""

from __future__ import annotations

from vehicles.params import VehicleParams

# Each vehicle parameter's range (VehicleParams' units): masses and inertias positive (the model divides by them),
# damping and forces not negative, magnitudes a vehicle can have.
PARAMETER_RANGES: dict[str, tuple[float, float]] = {
    "mass": (0.1, 1e6),
    "inertia": (1e-3, 1e7),
    "linear_damping": (0.0, 1e6),
    "quadratic_damping": (0.0, 1e6),
    "angular_linear_damping": (0.0, 1e6),
    "angular_quadratic_damping": (0.0, 1e6),
    "weight": (0.0, 1e8),
    "buoyancy": (0.0, 1e8),
    "center_of_buoyancy": (-10.0, 10.0),
    "max_surge_force": (0.0, 1e6),
    "max_torque": (0.0, 1e6),
    "lift_uv": (-1e6, 0.0),  # lift opposes the flow across the hull
    "lift_ur": (-1e6, 1e6),
    "lift_moment_uv": (-1e6, 1e6),
    "lift_moment_ur": (-1e6, 0.0),  # fin lift damps the rates
}


def out_of_range(params: VehicleParams) -> list[str]:
    """'name value, outside [low, high]' for each parameter of params outside its range."""
    out = []
    for name, (low, high) in PARAMETER_RANGES.items():
        value = getattr(params, name)
        values = value if isinstance(value, tuple) else (value,)
        if not all(low <= v <= high for v in values):
            shown = list(value) if isinstance(value, tuple) else value
            out.append(f"{name} {shown}, outside [{low:g}, {high:g}]")
    return out

"""Scenario sections of the plant as it differs from the controller's model: the ocean current ([environment]) and
the model mismatch ([vehicle] uncertainty). Each is off by default (still water, the nominal plant)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Discriminator, Field, JsonValue, Strict, Tag

from supervisor.config.schema_base import MAX_TIME, Float, Length, RenamedKeys, StrictModel, radians
from vehicles.params import PRESETS

MAX_CURRENT = 5.0  # m/s: a component of the current; the strongest tidal races run at 4-5 m/s
MAX_SHEAR = 1.0  # 1/s: 1 m/s more current per metre of depth is far beyond any ocean shear
MAX_SPREAD = 0.9  # a coefficient scaled by at least 0.1: masses and inertias stay positive

CurrentSpeed = Annotated[float, Strict(), Field(ge=-MAX_CURRENT, le=MAX_CURRENT)]
CurrentVector = tuple[CurrentSpeed, CurrentSpeed, CurrentSpeed]
Shear = Annotated[float, Strict(), Field(ge=-MAX_SHEAR, le=MAX_SHEAR)]
Spread = Annotated[float, Strict(), Field(ge=0, le=MAX_SPREAD)]


class TideSection(RenamedKeys):
    """A tidal stream added to the current: amplitude sin(2 pi t / period + phase_rad)."""

    amplitude: CurrentVector = Field(description="[ax, ay, az] of the tidal stream, m/s (inertial, z up)")
    period: Float = Field(gt=0, le=10 * MAX_TIME, description="s (the M2 tide: 44712 s = 12.42 h); positive")
    phase_rad: Float = radians("phase", "rad at t = 0")


class EnvironmentSection(StrictModel):
    """The water the vehicles move in: an ocean current v_c(t, p) = current + tide + shear (z - shear_origin),
    inertial frame, z up. Damping and added-mass terms act on the velocity relative to the water, which is the
    velocity a vehicle's state and log hold; its velocity over ground is R v + v_c (Fossen 2011, sec. 8.3)."""

    current: CurrentVector = Field(
        default=(0.0, 0.0, 0.0), description="[vx, vy, vz] of a steady uniform current, m/s (inertial, z up)"
    )
    tide: TideSection | None = Field(default=None, description="a tidal stream added to the current (none: steady)")
    shear: tuple[Shear, Shear] = Field(
        default=(0.0, 0.0),
        description="[dvx/dz, dvy/dz]: a linear horizontal shear in depth added to the current, 1/s (z up: a "
        "positive value is a current growing towards the surface)",
    )
    shear_origin: Length = Field(default=0.0, description="z where the shear adds nothing, m")
    current_known: Annotated[bool, Strict()] = Field(
        default=False,
        description="true: each controller knows the current where its vehicle is and feeds it forward; false: it "
        "steers as in still water",
    )
    estimate_current: Literal["auto", "on", "off"] = Field(
        default="auto",
        description="the on-board current observer whose estimate each controller feeds forward: auto (on where "
        "there is a current the controllers are not told), on, off (they steer as in still water)",
    )

    @property
    def still(self) -> bool:
        """No current of any kind: the vehicles move as they always did."""
        tide_off = self.tide is None or not any(self.tide.amplitude)
        return not any(self.current) and tide_off and not any(self.shear)


class UncertaintyTable(StrictModel):
    """Relative spread of each group of plant coefficients (0.2: each drawn within +-20 % of the nominal value)."""

    mass: Spread = Field(default=0.0, description="diagonal of M (rigid body + added mass)")
    inertia: Spread = Field(default=0.0, description="diagonal of J")
    linear_damping: Spread = Field(default=0.0, description="linear damping of surge, sway, heave")
    quadratic_damping: Spread = Field(default=0.0, description="quadratic damping of surge, sway, heave")
    angular_linear_damping: Spread = Field(default=0.0, description="linear damping of roll, pitch, yaw")
    angular_quadratic_damping: Spread = Field(default=0.0, description="quadratic damping of roll, pitch, yaw")
    buoyancy: Spread = Field(default=0.0, description="B, and with it the righting moment")
    net_weight: Spread = Field(default=0.0, description="W - B (of the net weight, not of W)")
    center_of_buoyancy: Spread = Field(default=0.0, description="each component of r_B")
    lift: Spread = Field(default=0.0, description="hull and fin lift: each of Y_uv, Y_ur, N_uv, N_ur (0 stays 0)")


def _number_or_table(value: object) -> str:
    """Which form of uncertainty a value is meant as, so that a bad table is not also reported as a bad number."""
    return "table" if isinstance(value, dict | UncertaintyTable) else "number"


Uncertainty = Annotated[
    Annotated[Spread, Tag("number")] | Annotated[UncertaintyTable, Tag("table")], Discriminator(_number_or_table)
]


def as_any_of(schema: dict[str, JsonValue]) -> None:
    """The JSON Schema of the number-or-table union as anyOf, as for every other such union (pydantic writes oneOf
    for a union told apart by a function, which the reference generator reads as a table with a type key)."""
    schema["anyOf"] = schema.pop("oneOf")


UNCERTAINTY_DESCRIPTION = (
    "model mismatch: the plant's coefficients drawn uniformly within +-uncertainty of the preset's (which the "
    "controller keeps), one draw per vehicle seeded by (scenario.seed, vehicle id); a number for every group of "
    f"coefficients (at most {MAX_SPREAD}), or a table of spreads per group; 0: the plant is the nominal model"
)


class ActuatorTable(StrictModel):
    """Fins and propeller between the controller and the vehicle (vehicles.actuators); the defaults are the REMUS
    100's ("remus100")."""

    fin_lift: Float = Field(default=6.15, gt=0, le=1e4, description="fin moment per (m/s)^2 and rad, N m s^2/(m^2 rad)")
    max_deflection_deg: Float = Field(default=13.6, gt=0, le=60, description="fin deflection limit, deg")
    fin_time_constant: Float = Field(default=0.1, gt=0, le=100, description="fin servo's time constant, s")
    thruster_time_constant: Float = Field(default=1.0, gt=0, le=100, description="propeller's time constant, s")
    max_rate_deg: Float | None = Field(default=None, gt=0, le=1000, description="fin rate limit, deg/s (absent: none)")


def _name_or_table(value: object) -> str:
    """Which form of actuators a value is meant as, so that a bad table is not also reported as a bad name."""
    return "table" if isinstance(value, dict | ActuatorTable) else "name"


Actuation = Annotated[
    Annotated[Literal["preset", "ideal", "remus100"], Tag("name")] | Annotated[ActuatorTable, Tag("table")],
    Discriminator(_name_or_table),
]
ACTUATORS = (  # [vehicle] actuators' description
    "what turns the controller's force and torques into motion: ideal (the paper's model: the inputs as asked, within "
    "the preset's limits), remus100 (a REMUS 100's fins and propeller from sources: vehicles/actuators.py), or a "
    "table of their parameters, each for every vehicle of the fleet; preset: each vehicle's own preset's (its "
    "[[vehicles]] preset, else [vehicle] preset: remus100's for remus100, ideal for the others and for another "
    "vehicle model)"
)


def known_preset(value: str | None) -> str | None:
    """A [vehicle] or [[vehicles]] preset, checked against the presets (vehicles.params)."""
    if value is not None and value not in PRESETS:
        raise ValueError(f"unknown preset, expected one of {sorted(PRESETS)}")
    return value

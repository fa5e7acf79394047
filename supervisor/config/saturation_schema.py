"""The [saturation] section: a top speed along the path and a bounded coordination correction (vehicles.saturation).
The top speed is off unless a scenario asks; the correction is bounded by what each vehicle's thrust allows unless
the scenario says none."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from supervisor.config.schema_base import MAX_GAIN, MAX_SPEED, Float, StrictModel


class SaturationSection(StrictModel):
    """Bounds on the coordination loop, so that a delayed or badly tuned loop stays bounded."""

    top_speed: Annotated[Float, Field(gt=0, le=MAX_SPEED)] | Literal["preset"] | None = Field(
        default=None,
        description="the largest speed a vehicle is asked to move along its path, m/s: |gamma_dot| is held to "
        "top_speed / |dp_d/dgamma| with no wind-up; preset: each vehicle's top speed (full thrust against its "
        "surge damping, as cpf presets shows); absent: unbounded",
    )
    correction: Annotated[Float, Field(gt=0, le=MAX_GAIN)] | Literal["preset", "none"] = Field(
        default="preset",
        description="bound c on the coordination correction v_tilde, unit of gamma per s^2: v_tilde is replaced by "
        "c tanh(v_tilde / c) (the saturated consensus of the FAROL stack); preset: c = half the vehicle's "
        "acceleration at full thrust / |dp_d/dgamma|, so the correction never asks more of a vehicle than it can "
        "follow (vehicles/saturation.py; a law whose correction does not vanish at agreement, as literal, then settles "
        "elsewhere); none: unbounded (law (5) as the paper has it)",
    )

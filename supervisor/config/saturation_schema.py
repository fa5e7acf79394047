"""The [saturation] section: a top speed along the path and a bounded coordination correction (vehicles.saturation).
Both off unless a scenario asks: law (5) and the path parameters as the paper has them."""

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
    correction: Float | None = Field(
        default=None, gt=0, le=MAX_GAIN,
        description="bound c on the coordination correction v_tilde of law (5), unit of gamma per s^2: v_tilde is "
        "replaced by c tanh(v_tilde / c) (the saturated consensus of the FAROL stack); absent: unbounded",
    )  # fmt: skip

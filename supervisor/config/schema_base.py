"""What every scenario model is built of: numbers as TOML writes them, the strict, frozen base model, and the bounds
every scenario value is held to.

The bounds keep every value where the model means something and no arithmetic of a run can overflow: a run fits the
modem frame's time stamp (u32 ms), positions fit an ocean, speeds fit an AUV. They are Field constraints, so the JSON
Schema and the scenario reference show them.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Annotated, Any

from pydantic import (
    AliasChoices,
    BaseModel,
    ConfigDict,
    Field,
    JsonValue,
    ModelWrapValidatorHandler,
    PrivateAttr,
    Strict,
    model_validator,
)

from comms.records.fields import MAX_SPEED, MAX_TIME
from comms.records.ids import MAX_VEHICLE_ID

__all__ = ["MAX_FLEET", "MAX_SPEED", "MAX_TIME", "MAX_VEHICLE_ID"]

# Numbers as TOML writes them: an integer is a valid float, a string ("400") or a boolean is not a number.
Float = Annotated[float, Strict()]
Int = Annotated[int, Strict()]
Vec3 = tuple[Float, Float, Float]

MAX_STEPS = 10_000_000  # sync steps of one run: hours of wall time already, and the log grows with every one
MIN_STEP = 1e-3  # s: the modem frame stamps times in ms; a shorter step gives two steps one time stamp
MAX_LENGTH = 1e7  # m: 10 000 km, larger than any ocean basin
MAX_DELAY = 3600.0  # s: no acoustic packet is an hour on its way
MAX_BODY_SPEED = 5.0  # m/s: an initial body velocity component; AUVs cruise at 1-3 m/s
MAX_BODY_RATE = 10.0  # rad/s: an initial body rate component
MAX_ANGLE = 1000.0  # rad: an angle beyond a few turns is a typo (degrees given for radians)
MAX_GAIN = 1e4  # a controller or coordination gain
MAX_GAMMA = 1e6  # units of gamma: gamma0, offsets, thresholds (float32 on the wire keeps 7 digits of it)
MAX_RATE = 1e6  # units of gamma per s: v_r, a gamma_dot cap
MAX_FLEET = 10_000  # vehicles: each has ~5 log channels (state, tx, rx, scene), and MCAP numbers channels in 16 bits
MAX_COUNT = 65_025  # items of a list that grows with the fleet (edges, links): a complete graph of 361 AUVs
MAX_BYTES = 1_000_000  # B: a packet or frame

Length = Annotated[float, Strict(), Field(ge=-MAX_LENGTH, le=MAX_LENGTH)]
Position = tuple[Length, Length, Length]
Speed = Annotated[float, Strict(), Field(ge=-MAX_BODY_SPEED, le=MAX_BODY_SPEED)]
Rate = Annotated[float, Strict(), Field(ge=-MAX_BODY_RATE, le=MAX_BODY_RATE)]
Degrees = Annotated[float, Strict(), Field(ge=-360, le=360)]
VehicleId = Annotated[int, Strict(), Field(ge=1, le=MAX_VEHICLE_ID)]
Seconds = Annotated[float, Strict(), Field(ge=0, le=MAX_TIME)]
Probability = Annotated[float, Strict(), Field(ge=0, le=1)]
# An extension's name: a built-in's or an installed entry point's (a Python identifier), or package.module:Name.
ExtensionName = Annotated[
    str, Strict(), Field(min_length=1, max_length=200, pattern=r"^[A-Za-z_][\w.-]*(:[A-Za-z_][\w.]*)?$")
]


def one_of(names: Iterable[str]) -> dict[str, JsonValue]:
    """The allowed names of a key checked by a validator, for the JSON Schema (editors complete them)."""
    choices: list[JsonValue] = [*sorted(names)]
    return {"enum": choices}


class StrictModel(BaseModel):
    # Lax mode so that TOML arrays become tuples; the numbers themselves are strict (Float, Int).
    # TOML has nan and inf literals; no field of a scenario may take them.
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False, allow_inf_nan=False)


# Angle keys say their unit in their name (issue 30); the names before the rename are still read, and said.
RENAMED = {"phase": "phase_rad", "heading": "heading_rad"}  # old name -> name


def radians(old: str, description: str) -> Any:
    """A Field for an angle in rad whose key was once `old` (still read: supervisor.config.unit_checks says so)."""
    name = RENAMED[old]
    return Field(
        default=0.0,
        ge=-MAX_ANGLE,
        le=MAX_ANGLE,
        description=f"{description}; `{old}` before, still read",
        validation_alias=AliasChoices(name, old),
    )


class RenamedKeys(StrictModel):
    """A model with an angle key renamed to say its unit: which old names the input used (`old_names`)."""

    _old_names: tuple[str, ...] = PrivateAttr(default=())

    @model_validator(mode="wrap")
    @classmethod
    def _note_old_names(cls, data: Any, handler: ModelWrapValidatorHandler[Any]) -> Any:
        old = tuple(k for k in data if RENAMED.get(k) in cls.model_fields) if isinstance(data, dict) else ()
        for key in old:
            if RENAMED[key] in data:
                raise ValueError(f"{key} is the old name of {RENAMED[key]}: give {RENAMED[key]} only")
        model = handler(data)
        if old and isinstance(model, RenamedKeys):
            model._old_names = old
        return model

    @property
    def old_names(self) -> tuple[str, ...]:
        return self._old_names

"""What every scenario model is built of: numbers as TOML writes them and the strict, frozen base model."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Annotated

from pydantic import BaseModel, ConfigDict, JsonValue, Strict

# Numbers as TOML writes them: an integer is a valid float, a string ("400") or a boolean is not a number.
Float = Annotated[float, Strict()]
Int = Annotated[int, Strict()]
Vec3 = tuple[Float, Float, Float]


def one_of(names: Iterable[str]) -> dict[str, JsonValue]:
    """The allowed names of a key checked by a validator, for the JSON Schema (editors complete them)."""
    choices: list[JsonValue] = [*sorted(names)]
    return {"enum": choices}


class StrictModel(BaseModel):
    # Lax mode so that TOML arrays become tuples; the numbers themselves are strict (Float, Int).
    # TOML has nan and inf literals; no field of a scenario may take them.
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False, allow_inf_nan=False)

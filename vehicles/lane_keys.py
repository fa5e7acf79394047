"""When parts of two vehicles are the same, to the bit, for vehicles.lanes to step them with one of them; and what
differs between them (an adaptive controller's memory) as one value of lanes.

Not ==: 0.0 == -0.0 (and a NaN is not itself), and a class may leave fields out of its == or its repr (a user's
controller with `field(repr=False)` grouped by repr stepped with another vehicle's gain). A key here walks every
field of a dataclass (its class named), takes a float by its bits and an array by its bytes; any other object is
known only by its identity, so it is the same as itself alone (keys are taken while the objects live: an id is not
reused meanwhile).
"""

from __future__ import annotations

import dataclasses
import struct
from typing import Any

import numpy as np

_DOUBLE = struct.Struct("<d")


def key(value: Any) -> object:
    """A hashable key equal for two values exactly when they are the same to the bit (as above)."""
    if value is None or isinstance(value, bool | int | str):
        return (type(value), value)
    if isinstance(value, float):
        return _DOUBLE.pack(value)
    if isinstance(value, tuple | list):
        return (type(value), tuple(key(v) for v in value))
    if isinstance(value, type):
        return ("class", value.__module__, value.__qualname__)
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.shape, value.tobytes())
    if dataclasses.is_dataclass(value):
        fields = tuple((f.name, key(getattr(value, f.name))) for f in dataclasses.fields(value))
        return ("class", type(value).__module__, type(value).__qualname__, fields)
    return ("object", id(value))


def stacked(values: list[Any]) -> Any:
    """One value of lanes for the vehicles' values of one shape: floats become an array (lane n: values[n]), tuples
    and dataclasses are stacked field by field (a dataclass made without its __init__, whose checks would refuse
    arrays: every field, derived ones too, is the lanes' own), and an object every vehicle shares (None, a constant)
    stays itself. Anything else raises TypeError (vehicles.lanes then steps them alone)."""
    first = values[0]
    if all(v is first for v in values):
        return first
    if all(type(v) is float for v in values):
        return np.array(values, dtype=np.float64)
    if isinstance(first, tuple) and not hasattr(first, "_fields") and all(_like(v, first) for v in values):
        return tuple(stacked(list(column)) for column in zip(*values, strict=True))
    if dataclasses.is_dataclass(first) and all(type(v) is type(first) for v in values):
        names = [f.name for f in dataclasses.fields(first)]
        return _made(type(first), {name: stacked([getattr(v, name) for v in values]) for name in names})
    raise TypeError(f"cannot step {type(first).__name__} values as lanes")


def unstacked(value: Any, lanes: int) -> list[Any]:
    """stacked's inverse: each lane's value (an object the lanes shared, each lane the same object)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, tuple) and not hasattr(value, "_fields") and any(_has_lanes(v) for v in value):
        return [tuple(column) for column in zip(*(unstacked(v, lanes) for v in value), strict=True)]
    if dataclasses.is_dataclass(value) and not isinstance(value, type) and _has_lanes(value):
        names = [f.name for f in dataclasses.fields(value)]
        columns = [unstacked(getattr(value, name), lanes) for name in names]
        return [_made(type(value), dict(zip(names, row, strict=True))) for row in zip(*columns, strict=True)]
    return [value] * lanes


def _made(cls: type, fields: dict[str, Any]) -> Any:
    """An instance of the dataclass cls with these fields, its __init__ (and checks) not run: frozen or not."""
    made: Any = object.__new__(cls)
    for name, value in fields.items():
        object.__setattr__(made, name, value)
    return made


def _like(value: Any, first: tuple[Any, ...]) -> bool:
    return type(value) is tuple and len(value) == len(first)


def _has_lanes(value: Any) -> bool:
    if isinstance(value, np.ndarray):
        return True
    if isinstance(value, tuple):
        return any(_has_lanes(v) for v in value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return any(_has_lanes(getattr(value, f.name)) for f in dataclasses.fields(value))
    return False

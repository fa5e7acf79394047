"""When parts of two vehicles are the same, to the bit, for vehicles.lanes to step them with one of them.

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

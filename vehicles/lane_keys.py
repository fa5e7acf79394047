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


class Interned:
    """A key (key()'s deep tuples) hashed once, one object for equal keys (interned): a step groups a thousand
    vehicles by their shapes, and hashing each shape's tuples again cost 4 us a vehicle a step."""

    __slots__ = ("_hash", "value")

    def __init__(self, value: object) -> None:
        self.value, self._hash = value, hash(value)

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        return isinstance(other, Interned) and self._hash == other._hash and self.value == other.value


_INTERNED: dict[Interned, Interned] = {}  # bounded: a long sweep's configurations come and go
_MOST_INTERNED = 4096


def interned(value: Any) -> Interned:
    """key(value), hashed once; the same object for values of equal keys while it is held here (else an equal one)."""
    made = Interned(key(value))
    if len(_INTERNED) >= _MOST_INTERNED:
        _INTERNED.clear()
    return _INTERNED.setdefault(made, made)


# Values lanes share only when equal (each lane gets the value itself).
_ATOMS = (bool, int, str, bytes, type(None))


def stacked(values: list[Any]) -> Any:
    """One value of lanes for the vehicles' values of one shape: floats become an array (lane n: values[n]; a float
    every lane holds as one object stays itself), tuples, named tuples and dataclasses are stacked attribute by
    attribute (a dataclass made without its __init__, whose checks would refuse arrays: every attribute it holds,
    fields and what __post_init__ set alike, is the lanes' own), None, ints, strings and bools stay themselves where
    every lane's is equal. Anything else (an array, a list, a dict, values that differ in type, length or
    attributes) raises TypeError: vehicles.lanes then steps them alone."""
    first = values[0]
    kind = type(first)
    if any(type(v) is not kind for v in values):
        raise TypeError(f"cannot step values of types {kind.__name__} and others as lanes")
    if kind is float:
        return first if all(v is first for v in values) else np.array(values, dtype=np.float64)
    if kind in _ATOMS and all(v == first for v in values):
        return first
    if issubclass(kind, tuple) and all(len(v) == len(first) for v in values):
        return _tuple_of(kind, [stacked(list(column)) for column in zip(*values, strict=True)])
    if dataclasses.is_dataclass(first):
        names = _attributes(first)
        if any(_attributes(v) != names for v in values):
            raise TypeError(f"{kind.__name__} values hold different attributes")
        return _made(kind, {name: stacked([getattr(v, name) for v in values]) for name in names})
    raise TypeError(f"cannot step {kind.__name__} values as lanes")


def unstacked(value: Any, lanes: int, like: Any) -> list[Any]:
    """Each lane's part of value, which a step of lanes made from like (what stacked gave it): an array of one value
    per lane where like held a float or such an array, a float or an atom the lanes share (each lane that value),
    tuples, named tuples and dataclasses part by part. TypeError for anything else: an array where like held no
    float (a memory's own array, whatever its length, is not lanes), a list, a dict; the vehicles then step alone."""
    if isinstance(value, np.ndarray):
        if value.shape != (lanes,) or not isinstance(like, float | np.ndarray):
            raise TypeError(f"an array of shape {value.shape} is not one value per lane of {lanes} here")
        return value.tolist()
    kind = type(value)
    if isinstance(value, float):
        return [float(value)] * lanes
    if kind in _ATOMS:
        return [value] * lanes
    if issubclass(kind, tuple):
        parts = like if type(like) is kind and len(like) == len(value) else (None,) * len(value)
        columns = [unstacked(v, lanes, p) for v, p in zip(value, parts, strict=True)]
        return [_tuple_of(kind, list(row)) for row in zip(*columns, strict=True)] if columns else [value] * lanes
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        names = _attributes(value)
        columns = [unstacked(getattr(value, n), lanes, getattr(like, n, None)) for n in names]
        return [_made(kind, dict(zip(names, row, strict=True))) for row in zip(*columns, strict=True)]
    raise TypeError(f"cannot take {kind.__name__} values apart into lanes")


def _attributes(value: Any) -> list[str]:
    """Every attribute the instance holds: its slots (those set) over its classes, then its __dict__'s."""
    names = [
        name for cls in type(value).__mro__ for name in _slots(cls)
        if name not in ("__dict__", "__weakref__") and _holds(value, name)
    ]  # fmt: skip
    return names + [name for name in getattr(value, "__dict__", {}) if name not in names]


def _slots(cls: type) -> tuple[str, ...]:
    slots = vars(cls).get("__slots__", ())
    return (slots,) if isinstance(slots, str) else tuple(slots)


def _holds(value: Any, name: str) -> bool:
    try:
        object.__getattribute__(value, name)
    except AttributeError:
        return False
    return True


def _tuple_of(kind: type, items: list[Any]) -> Any:
    """A tuple of kind (a plain one, or a named tuple) of items; TypeError for another tuple subclass."""
    if kind is tuple:
        return tuple(items)
    make = getattr(kind, "_make", None)
    if make is None:
        raise TypeError(f"cannot make a {kind.__name__} of lanes")
    return make(items)


def _made(cls: type, attributes: dict[str, Any]) -> Any:
    """An instance of the dataclass cls holding these attributes, its __init__ (and checks) not run: frozen or
    not."""
    made: Any = object.__new__(cls)
    for name, value in attributes.items():
        object.__setattr__(made, name, value)
    return made

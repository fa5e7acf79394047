"""The scalar functions' branches over numpy arrays of lanes (many vehicles at once: vehicles.lanes), the same bits.

numpy's elementwise +, -, *, / and sqrt round as Python's floats do (IEEE-754, correctly rounded; numpy contracts
nothing into an FMA), so float code written with them takes arrays unchanged. What branches on a value cannot: each
function here takes a float or an array and, given an array, does lane by lane what the float code does (Python's
min returns its first argument unless the second is smaller: -0.0 and NaN included). The elementary functions
that lanes use take arrays themselves (numerics' sincos, cos, atan2 and tanh): on arrays of FEW_LANES or more, their
branches chosen lane by lane with where; on fewer, the scalar code of each lane (`each`), cheaper there.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np


def is_lanes(x: object) -> bool:
    return isinstance(x, np.ndarray)


def takes_lanes(part: object) -> bool:
    """Whether part (a controller, model, path...) says its float code takes arrays of lanes: a class attribute
    `lanes = True`, exactly (vehicles.lanes, docs/extending.md)."""
    return getattr(part, "lanes", False) is True


def sqrt(x: Any) -> Any:
    """math.sqrt of a float, numpy's (also correctly rounded) of an array."""
    return np.sqrt(x) if isinstance(x, np.ndarray) else math.sqrt(x)


def least(a: Any, b: Any) -> Any:
    """min(a, b) lane by lane: b where b < a, else a."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.where(b < a, b, a)
    return min(a, b)


def greatest(a: Any, b: Any) -> Any:
    """max(a, b) lane by lane: b where b > a, else a."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.where(b > a, b, a)
    return max(a, b)


def copysign(x: Any, sign: Any) -> Any:
    """math.copysign(x, sign), lane by lane for lanes (numpy's is the same bit operation)."""
    if isinstance(x, np.ndarray) or isinstance(sign, np.ndarray):
        return np.copysign(x, sign)
    return math.copysign(x, sign)


# Below this many lanes an elementary function's array form (70-90 us of numpy calls whatever the lanes) costs more
# than its scalar code lane by lane (about 1 us a lane): measured crossovers 72 (atan2), 80 (sincos), 96 (tanh).
FEW_LANES = 80


def each(f: Callable[..., float], *xs: Any) -> np.ndarray:
    """f of every lane (the arrays broadcast to one shape, 1-D), through the scalar code."""
    arrays = np.broadcast_arrays(*xs)
    return np.fromiter(map(f, *(a.tolist() for a in arrays)), dtype=np.float64, count=arrays[0].size)

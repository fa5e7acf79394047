"""A value worked out from a whole scenario, once per Scenario object: a fleet of N vehicles builds N vehicle
configurations, each of which needs the fleet's fitted coupling gain (O(links) to work out), so 1000 AUVs paid
10^6 link visits for one number.

A Scenario is frozen (schema_base.StrictModel) and so cannot change under its entry, and it is not hashable (it holds
dicts), hence a cache by identity whose entry goes with the object (a weak reference's callback), not lru_cache.
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Callable
from typing import TypeVar

from supervisor.config.scenario_schema import Scenario

R = TypeVar("R")


def per_scenario(compute: Callable[[Scenario], R]) -> Callable[[Scenario], R]:
    """compute(scenario), worked out once per Scenario object."""
    cache: dict[int, tuple[weakref.ref[Scenario], R]] = {}

    @functools.wraps(compute)
    def once(scenario: Scenario) -> R:
        key = id(scenario)
        entry = cache.get(key)
        if entry is not None and entry[0]() is scenario:
            return entry[1]
        value = compute(scenario)
        cache[key] = (weakref.ref(scenario, lambda _, key=key: cache.pop(key, None)), value)  # type: ignore[misc]
        return value

    return once

"""Values that only make sense in another unit than their key's, said as warnings by `cpf validate` and `cpf run`.

A scenario gives angles in rad unless the key's name says deg (the schema's rule: path `phase` and `heading` are rad,
`attitude_rpy_deg` is deg). A radian key above one turn (2 pi) was almost surely written in degrees; a degree key
whose values are all within one radian-turn, not whole and not zero, almost surely in radians. Times against the
modem's airtime and the transmit period are supervisor.config.feasibility_checks's.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from supervisor.config.scenario_schema import Scenario

RADIAN_KEYS = ("phase", "heading")  # path keys in rad


def unit_warnings(sc: Scenario) -> list[str]:
    return [*_radians(sc), *_degrees(sc)]


def _radians(sc: Scenario) -> Iterator[str]:
    for index, vehicle in enumerate(sc.vehicles):
        spec = vehicle.path.model_dump()
        for key in RADIAN_KEYS:
            value = spec.get(key)
            if isinstance(value, float) and abs(value) > 2 * math.pi:
                yield (f"vehicles[{index}].path.{key}: in rad, and {value:g} rad is more than a turn: degrees? "
                       f"({value:g} deg is {math.radians(value):.6g} rad), got {value}")  # fmt: skip


def _degrees(sc: Scenario) -> Iterator[str]:
    for index, vehicle in enumerate(sc.vehicles):
        angles = vehicle.attitude_rpy_deg
        fractional = [a for a in angles if a != round(a)]
        if fractional and all(abs(a) <= 2 * math.pi for a in angles):
            shown = [round(math.degrees(a), 4) for a in angles]
            yield (f"vehicles[{index}].attitude_rpy_deg: in deg, and these look like rad (as deg: {shown}), "
                   f"got {list(angles)}")  # fmt: skip

"""Values that only make sense in another unit than their key's, said as warnings by `cpf validate` and `cpf run`.

Every angle key says its unit in its name (`phase_rad`, `heading_rad`, `attitude_rpy_deg`); the names before that
(`phase`, `heading`) are still read as rad, and said. A radian key above one turn (2 pi) was almost surely written in
degrees; a degree key whose values are all within one radian-turn, not whole and not zero, almost surely in radians.
Times against the modem's airtime and the transmit period are supervisor.config.feasibility_checks's.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from supervisor.config.scenario_schema import Scenario
from supervisor.config.schema_base import RENAMED, RenamedKeys


def unit_warnings(sc: Scenario) -> list[str]:
    return [*_radians(sc), *_degrees(sc)]


def _with_radians(sc: Scenario) -> Iterator[tuple[str, RenamedKeys]]:
    """(where, table) of every table with a key in rad."""
    for index, vehicle in enumerate(sc.vehicles):
        if isinstance(vehicle.path, RenamedKeys):
            yield f"vehicles[{index}].path", vehicle.path
    if sc.environment.tide is not None:
        yield "environment.tide", sc.environment.tide


def _radians(sc: Scenario) -> Iterator[str]:
    for where, table in _with_radians(sc):
        for old in table.old_names:
            yield f"{where}.{old}: read as {RENAMED[old]} (rad), its name now; write {RENAMED[old]}"
        for key in RENAMED.values():
            value = getattr(table, key, None)
            if isinstance(value, float) and abs(value) > 2 * math.pi:
                yield (f"{where}.{key}: in rad, and {value:g} rad is more than a turn: degrees? "
                       f"({value:g} deg is {math.radians(value):.6g} rad), got {value}")  # fmt: skip


def _degrees(sc: Scenario) -> Iterator[str]:
    for index, vehicle in enumerate(sc.vehicles):
        angles = vehicle.attitude_rpy_deg
        fractional = [a for a in angles if a != round(a)]
        if fractional and all(abs(a) <= 2 * math.pi for a in angles):
            shown = [round(math.degrees(a), 4) for a in angles]
            yield (f"vehicles[{index}].attitude_rpy_deg: in deg, and these look like rad (as deg: {shown}), "
                   f"got {list(angles)}")  # fmt: skip

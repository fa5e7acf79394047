"""Vehicle hosts: how many vehicles each OS process of a Zenoh run serves, and which (pure; the supervisor asks).

One process per vehicle is the default while the machine can carry it. A process costs its interpreter, its imports
(~50 MB, ~0.2 s) and a scheduling slot on every step; past twice as many vehicles as cores, the processes mostly wait
for each other's turn on the cores, so the default groups the fleet into one host per core (vehicles.host: each
vehicle still on its own Zenoh session, with its own credential, keys and token).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

HOST_PREFIX = "vehicles "  # a host's process name: "vehicles 4,5,6" (a lone vehicle's: "vehicle 4")


def cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def default_per_process(fleet: int, cores: int) -> int:
    """Vehicles per process when the user does not say: 1 while the fleet is at most twice the cores, else
    ceil(fleet / cores) (one host per core)."""
    if fleet <= 2 * cores:
        return 1
    return math.ceil(fleet / cores)


def groups(ids: Sequence[int], per_process: int) -> list[tuple[int, ...]]:
    """The vehicles in processes of at most per_process, as few processes as that allows and as even as can be (50
    by 20: 17, 17, 16), in the order of ids."""
    if not ids:
        return []
    count = math.ceil(len(ids) / per_process)
    size, extra = divmod(len(ids), count)
    out, start = [], 0
    for index in range(count):
        end = start + size + (1 if index < extra else 0)
        out.append(tuple(ids[start:end]))
        start = end
    return out


def host_name(ids: Sequence[int]) -> str:
    """The process name of a host of ids (several), as the supervisor and its process group know it."""
    return HOST_PREFIX + ",".join(str(v) for v in ids)


def hosted_ids(name: str) -> tuple[int, ...] | None:
    """The vehicles of a host's process name; None for any other process."""
    if not name.startswith(HOST_PREFIX):
        return None
    return tuple(int(part) for part in name.removeprefix(HOST_PREFIX).split(","))


def hosts_chosen(fleet: int, cores: int, per_process: int) -> str:
    """What the default chose, said once on stderr: '50 vehicles on 2 cores: 2 vehicle hosts of up to 25 each ...'."""
    hosts = len(groups(range(fleet), per_process))
    return (
        f"{fleet} vehicles on {cores} core{'s' if cores != 1 else ''}: {hosts} vehicle host{'s' if hosts != 1 else ''} "
        f"of up to {per_process} vehicles each (--vehicles-per-process 1: one process per vehicle)"
    )

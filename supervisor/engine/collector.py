"""The pace of Python's cyclic garbage collector while our code runs.

A run makes millions of small objects that reference counting frees at once (a step's records, messages, floats)
and keeps a large heap that only grows (the fleet, its series, the scene's history). CPython's collector starts a
young collection every 700 new container objects and, every 100 of those, a full one once the survivors since the
last have grown by a quarter of the heap: a fleet of 1000 AUVs paid ~57 full scans of its whole heap in 10 s
simulated, ~18 % of the command (the same run with the collector off: 16.2 -> 13.3 s, the same peak memory: our
objects make no cycles worth the scans). A young collection every YOUNG instead keeps collecting cycles, and leaves
a small fleet as it was (`benchmarks.bench_collector`). It changes no result: the collector frees memory, nothing
else.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

YOUNG = 10_000  # container objects made between young collections (CPython's default: 700)


def pace() -> None:
    """For a process that is ours from start to end (a `cpf` command, a sweep's worker): YOUNG from now on, the
    older generations' thresholds as they were."""
    _, middle, old = gc.get_threshold()
    gc.set_threshold(YOUNG, middle, old)


@contextmanager
def paced() -> Iterator[None]:
    """pace() for the block, then the thresholds the caller had (the Python API: a notebook's interpreter is the
    user's)."""
    before = gc.get_threshold()
    pace()
    try:
        yield
    finally:
        gc.set_threshold(*before)

"""The pace of Python's cyclic garbage collector while our code runs.

A run makes millions of small objects that reference counting frees at once (a step's records, messages, floats)
and keeps a large heap that only grows (the fleet, its series, the scene's history). CPython's collector starts a
young collection every 700 new container objects and, every 100 of those, a full one once the survivors since the
last have grown by a quarter of the heap: a fleet of 1000 AUVs paid ~57 full scans of its whole heap in 10 s
simulated, ~18 % of the command (the same run with the collector off: 16.2 -> 13.3 s, the same peak memory: our
objects make no cycles worth the scans). A young collection every YOUNG instead keeps collecting cycles, and leaves
a small fleet as it was (`benchmarks.bench_collector`). It changes no result: the collector frees memory, nothing
else. Set by cpf's main for the process it runs in (a `cpf` command, and the vehicle and broker processes a run
starts, forked or spawned, which run through it), by a local sweep's workers, and for the length of cpf.run; not in
the fork server, the live relay or a Dask cluster's workers (a cluster is the user's).

Why YOUNG is what it is: CPython counts container objects made less those freed since the last collection, so the
threshold is crossed by what stays alive, and what a step keeps alive until it ends (a job, a state, its records
and messages for each vehicle) is ~10 tracked objects a vehicle. Below that working set, a large fleet's every step
crosses the threshold and each collection walks the step's live objects, then moves them to be walked again: at
10,000 a ring of 1000 AUVs (60 s) made 1183 young collections, 3.8 s of collecting in all; at 50,000, above the
steps of such a fleet, 51, 0.6 s, the command 2.5 s shorter. Cycles still go within 50,000 objects (a few MB).
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator
from contextlib import contextmanager

YOUNG = 50_000  # container objects made less those freed between young collections (CPython's default: 700)

_LOCK = threading.Lock()
_HELD: list[tuple[int, int, int]] = []  # the thresholds before the first of the runs paced now (cpf.run in threads)
_PACED = [0]  # how many such runs are going
_PAUSED = [0]  # how many paused() blocks are open
_WAS_ON = [True]  # whether the collector ran before the first of them


def pace() -> None:
    """For a process that is ours from start to end: YOUNG from now on, the older generations' thresholds as they
    were; a collector switched off (a young threshold of 0) stays off."""
    young, middle, old = gc.get_threshold()
    if young != 0:
        gc.set_threshold(YOUNG, middle, old)


@contextmanager
def paced() -> Iterator[None]:
    """pace() for the block, then the thresholds the caller had (the Python API: a notebook's interpreter is the
    user's). Blocks in several threads at once: the thresholds of before the first are given back after the last."""
    entered = False
    try:
        with _LOCK:
            held = gc.get_threshold()
            # Counted and marked with no call between (a Ctrl-C is raised at a call): once the thresholds change,
            # the finally gives them back.
            _PACED[0] += 1
            entered = True
            if _PACED[0] == 1:
                _HELD[:] = [held]
                pace()
        yield
    finally:
        if entered:
            with _LOCK:
                _PACED[0] -= 1
                if _PACED[0] == 0:
                    gc.set_threshold(*_HELD[0])


@contextmanager
def paused() -> Iterator[None]:
    """The collector off for the block, as it was after (nested, or in several threads: on again after the last),
    for work known to make no reference cycles that keeps a large heap alive: the Foxglove scene written after a run
    (record.scene: dicts, lists and floats, made and written one instant at a time), where each full collection
    scanned the whole run's heap: the scene of a ring of 1000 AUVs' 20 s log was built and encoded in 2.30 s, in
    1.67 s with the collector off. Cycles made meanwhile are collected after."""
    entered = False
    try:
        with _LOCK:
            was_on = gc.isenabled()
            _PAUSED[0] += 1  # as in paced: counted and marked before the collector is touched
            entered = True
            if _PAUSED[0] == 1:
                _WAS_ON[0] = was_on
                gc.disable()
        yield
    finally:
        if entered:
            with _LOCK:
                _PAUSED[0] -= 1
                if _PAUSED[0] == 0 and _WAS_ON[0]:
                    gc.enable()

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
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Any

YOUNG = 50_000  # container objects made less those freed between young collections (CPython's default: 700)

_LOCK = threading.Lock()


class _Shared:
    """A change to this process's collector that overlapping blocks share (cpf.run in threads, a scene written in
    each): the first block to enter reads what was and makes the change, the last to leave puts back what was."""

    def __init__(self, read: Callable[[], Any], change: Callable[[], None], undo: Callable[[Any], None]) -> None:
        self.read, self.change, self.undo = read, change, undo
        self.count = 0  # the blocks in force
        self.before: Any = None  # what the first of them read

    @contextmanager
    def block(self) -> Iterator[None]:
        entered = False
        try:
            with _LOCK:
                before = self.read()
                # Counted and marked with no call between (a Ctrl-C is raised at a call): once the collector is
                # changed, the finally puts it back.
                self.count += 1
                entered = True
                if self.count == 1:
                    self.before = before
                    self.change()
            yield
        finally:
            if entered:
                with _LOCK:
                    self.count -= 1
                    if self.count == 0:
                        self.undo(self.before)


def pace() -> None:
    """For a process that is ours from start to end: YOUNG from now on, the older generations' thresholds as they
    were; a collector switched off (a young threshold of 0) stays off."""
    young, middle, old = gc.get_threshold()
    if young != 0:
        gc.set_threshold(YOUNG, middle, old)


def paced() -> AbstractContextManager[None]:
    """pace() for the block, then the thresholds the caller had (the Python API: a notebook's interpreter is the
    user's). Blocks in several threads at once: the thresholds of before the first are given back after the last."""
    return _PACE.block()


def paused() -> AbstractContextManager[None]:
    """The collector off for the block, as it was after (nested, or in several threads: on again after the last),
    for work known to make no reference cycles that keeps a large heap alive: the Foxglove scene written after a run
    (record.scene: dicts, lists and floats, made and written one instant at a time), where each full collection
    scanned the whole run's heap: the scene of a ring of 1000 AUVs' 20 s log was built and encoded in 2.30 s, in
    1.67 s with the collector off. Cycles made meanwhile are collected after."""
    return _PAUSE.block()


_PACE = _Shared(gc.get_threshold, pace, lambda held: gc.set_threshold(*held))
_PAUSE = _Shared(gc.isenabled, gc.disable, lambda was_on: gc.enable() if was_on else None)

"""Drawing a report's figures on every core.

matplotlib draws one figure at a time on one core, and a report is many independent figures (an 8-vehicle run: 16,
15 s of drawing against 4 s of reading its log), so `draw` hands them to worker processes forked from this one: a
worker inherits the run in memory (nothing is copied through a pipe), builds its figures by name and saves them.
The PNGs are the same bytes as those drawn one by one (tests/test_report.py).

Forking is safe only in a process with no other thread (a lock another thread held would stay held in the child):
with other threads alive (a notebook's kernel, a test runner's helpers), on one core, or for a few figures, they are
drawn here one after the other. Workers ignore Ctrl-C (their parent ends the pool) and are killed by the kernel when
their parent dies (comms.bus.lifeline's parent-death signal): nothing is left behind. A worker that dies (SIGKILL,
the kernel's OOM killer) ends the report with one line, its other workers killed: concurrent.futures says so
(BrokenProcessPool) where multiprocessing.Pool waited for its lost figure for ever.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.queues import SimpleQueue
from pathlib import Path

from matplotlib.figure import Figure

from comms.bus.lifeline import ORPHANED, set_parent_death_signal
from supervisor.analysis.aside import signals_held
from supervisor.analysis.figures import save
from supervisor.analysis.rundata import RunData
from supervisor.errors import CpfError

__all__ = ["MIN_PARALLEL", "draw", "workers"]

Builder = Callable[[RunData], Figure]
MIN_PARALLEL = 4  # fewer figures than this are drawn here: a worker's start is not worth it

# What a forked worker inherits: the run, its figures and where they go (set by `draw` just before the fork).
_job: tuple[RunData, dict[str, Builder], Path] | None = None


def workers(figures: int) -> int:
    """How many processes draw `figures` figures: the cores this process may use, at most one per figure; 1 (here)
    when forking is unsafe (another thread alive) or not worth it."""
    if figures < MIN_PARALLEL or threading.active_count() > 1 or not hasattr(os, "fork"):
        return 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return max(1, min(cores, figures))


def draw(run: RunData, figures: Sequence[tuple[str, Builder]], out_dir: Path, processes: int) -> list[Path]:
    """Each figure built and saved as out_dir/<name>.png, by `processes` forked workers (1: here); the paths in
    the order of figures. A figure that fails raises here, as drawn in this process."""
    if processes <= 1:
        return [save(build(run), out_dir / f"{name}.png") for name, build in figures]
    global _job
    _job = (run, dict(figures), out_dir)
    context = multiprocessing.get_context("fork")
    started: SimpleQueue[int] = context.SimpleQueue()  # each worker's pid: to kill them if the report ends early
    pool = ProcessPoolExecutor(
        processes, mp_context=context, initializer=_worker_start, initargs=(os.getpid(), started)
    )
    done = False
    try:
        # A worker that dies breaks the pool for the submits still to come as for the results (CI killed one while
        # the figures were being handed out): either way one line.
        try:
            with signals_held():  # a Ctrl-C while the workers are forked would leave the pool half-made
                # Last first: a report's last figures are the channel's, of a panel per link and the slowest (an
                # 8-vehicle run: 1-2 s each against 0.3 s); begun first, the workers end together. (The first
                # submit forks every worker, before the pool's own thread starts.)
                futures: list[Future[Path]] = [pool.submit(_draw_one, name) for name, _ in reversed(figures)]
            paths = [future.result() for future in futures][::-1]
        except BrokenProcessPool:
            raise CpfError("a process drawing the report's figures died (killed?): no report written") from None
        done = True
        return paths
    finally:
        _job = None
        _end(pool, started, done)


def _end(pool: ProcessPoolExecutor, started: SimpleQueue[int], done: bool) -> None:
    """The pool shut down: its workers let end by themselves after a whole report, else killed at once."""
    if done:
        pool.shutdown(wait=True)
        return
    pool.shutdown(wait=False, cancel_futures=True)
    while not started.empty():
        with contextlib.suppress(ProcessLookupError):  # (a child's pid stays ours until it is reaped)
            os.kill(started.get(), signal.SIGKILL)


def _worker_start(parent: int, started: SimpleQueue[int]) -> None:
    started.put(os.getpid())
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent ends the pool
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # how the pool ends a worker; cpf's own handler raises in it
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # held by signals_held
    if set_parent_death_signal(signal.SIGKILL) and os.getppid() != parent:
        os._exit(ORPHANED)  # the parent died before the prctl: the signal would never come


def _draw_one(name: str) -> Path:
    assert _job is not None, "a worker forked by draw inherits its job"
    run, builders, out_dir = _job
    return save(builders[name](run), out_dir / f"{name}.png")

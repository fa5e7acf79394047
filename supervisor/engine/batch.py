"""Many runs of the in-process engine at once, in lockstep, nothing recorded: a sweep's runs (issue 26).

Each run is the in-process engine's own (supervisor.engine.inprocess.InProcessRun: its plan, channel, books and series,
each run's seed), stepped one step at a time, every run's step k before any run's step k + 1; only its vehicles'
steps are taken together, all runs' at once (vehicles.lanes.step_all), so that the same vehicle of many runs steps
as one group of lanes. Each run's result is the one run_inprocess gives it without a log (tests/test_batch.py), its
wall time the batch's shared equally. A run that fails (its SimulationError, or anything it raises) ends alone,
handed back in its place; the others go on.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Sequence
from dataclasses import dataclass

from supervisor.config.derived import steps_of
from supervisor.config.scenario_schema import Scenario
from supervisor.engine import interrupts
from supervisor.engine.inprocess import InProcessRun, RunResult, result, started
from supervisor.plan.schedule import StepPlan
from supervisor.record.recorder import Tally
from vehicles.lanes import Job, step_all


@dataclass(frozen=True, slots=True)
class BatchRun:
    """run_inprocess's arguments for one run of a batch."""

    scenario: Scenario
    scenario_file: str
    scenario_toml: str
    seed: int


@dataclass(slots=True)
class _Live:
    index: int
    run: InProcessRun
    rec: Tally
    steps: int
    planned: tuple[StepPlan, list[Job]] | None = None


@interrupts.deferring
def run_batch(runs: Sequence[BatchRun]) -> list[RunResult | Exception]:
    """Each run's result (or what ended it), in order."""
    began = time.monotonic()
    results: list[RunResult | Exception | None] = [None] * len(runs)
    ended: list[tuple[_Live, float]] = []  # finished runs, with their stepping's end
    with contextlib.ExitStack() as stack:
        live = [entry for n, run in enumerate(runs) if (entry := _start(n, run, stack, results)) is not None]
        k = 0
        while live:
            live = _step(live, k, results)
            k += 1
            done = [entry for entry in live if entry.steps == k]
            for entry in done:
                _end(entry, results, ended)
            live = [entry for entry in live if entry.steps > k]
            interrupts.check()  # a safe point: a stop asked for (Ctrl-C, the sweep's SIGTERM) ends the batch here
    wall = (time.monotonic() - began) / max(1, len(runs))
    for entry, end in ended:
        try:
            results[entry.index] = result(entry.run, entry.rec, end, wall, wall)
        except Exception as exc:
            results[entry.index] = exc
    return [r if r is not None else RuntimeError("run did not end") for r in results]


def _start(
    index: int, run: BatchRun, stack: contextlib.ExitStack, results: list[RunResult | Exception | None]
) -> _Live | None:
    """The run started (None: it failed to, its exception in results)."""
    rec = stack.enter_context(Tally())
    try:
        started_run = started(run.scenario, run.scenario_file, run.scenario_toml, run.seed, rec, "lockstep")
    except Exception as exc:
        results[index] = exc
        return None
    return _Live(index, started_run, rec, steps_of(run.scenario))


def _step(live: list[_Live], k: int, results: list[RunResult | Exception | None]) -> list[_Live]:
    """Step k of every live run; those that failed leave, their exception in results."""
    going = []
    for entry in live:
        try:
            entry.planned = entry.run.begin(k)
            going.append(entry)
        except Exception as exc:  # this run's failure, not the batch's
            results[entry.index] = exc
    outcomes = step_all([job for entry in going for job in _jobs(entry)])
    stepped, at = [], 0
    for entry in going:
        plan, jobs = _planned(entry)
        mine, at = outcomes[at : at + len(jobs)], at + len(jobs)
        try:
            entry.run.take(plan, mine)
            stepped.append(entry)
        except Exception as exc:
            results[entry.index] = exc
    return stepped


def _jobs(entry: _Live) -> list[Job]:
    return _planned(entry)[1]


def _planned(entry: _Live) -> tuple[StepPlan, list[Job]]:
    assert entry.planned is not None
    return entry.planned


def _end(entry: _Live, results: list[RunResult | Exception | None], ended: list[tuple[_Live, float]]) -> None:
    end = entry.steps * entry.run.dt
    try:
        entry.run.finish(end)
    except Exception as exc:
        results[entry.index] = exc
        return
    ended.append((entry, end))

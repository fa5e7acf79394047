"""Monte-Carlo robustness sweeps: one scenario over a grid of parameter values and seeds.

`cpf sweep SCENARIO --param comms.loss=0,0.1,0.2 [--param ...] --seeds 20 --jobs N --out DIR` runs every
combination (each with its own seed), one process per job, or on a Dask cluster with --cluster ADDRESS
(supervisor.tools.sweep_cluster). Every finished run's row comes back here and is left in DIR/runs/<id>.json, so an
interrupted sweep resumes where it stopped. Results: DIR/results.csv (one row per run) and, per swept parameter, a
plot of the steady-state coordination error and the packets sent and delivered against it, with the spread across
seeds. Steady state: the largest max|gamma_i - gamma_j| over the final STEADY_STATE_WINDOW seconds of a run.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import json
import math
import os
import signal
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, CancelledError, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from itertools import islice, pairwise, product
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

from comms.bus.lifeline import ORPHANED, set_parent_death_signal
from supervisor import collector
from supervisor.errors import ScenarioError, SimulationError
from supervisor.tools.sweep_params import Param
from supervisor.tools.sweep_runs import MAX_BATCH, RunSpec, batch_limit, override, run_logged, run_many, run_one

if TYPE_CHECKING:
    from supervisor.config.scenario_schema import Scenario

WATCH_INTERVAL = 1.0  # s between looks at a cluster's workers while no run finishes
# Batches go to whichever worker is free first (list scheduling), in grid order, so that a batch's runs are alike
# (lanes). Where the swept values change a run's size (steps x vehicles: a swept duration or step), one batch a
# worker left one worker with most of the work (the review: 1.6-2.1x the balanced time). Graham's bound (Bell Syst.
# Tech. J. 45, 1966) puts the last worker to finish at most one batch past the mean load: four batches a worker keep
# such sweeps within ~1.25x of balanced. Runs of one size keep one batch a worker (lanes: batches of 25 paper runs
# cost ~10 % more CPU than of 50, measured).
BATCHES_PER_WORKER = 4
# Combinations of the other swept values a value that is not valid alone is tried with (_valid_with): enough for any
# sweep of a few parameters, and a bound on the start-up a hopeless value costs (~13 ms a scenario loaded).
COMBINATIONS_TRIED = 256
SCENARIO_DIGEST = "scenario.sha256"  # in DIR/runs: the sha-256 of the scenario file whose runs are there


def default_jobs(cores: int) -> int:
    """Runs at once when the user does not say: one per core, on either engine. An in-process run is one busy
    thread; a Zenoh run keeps ~1.5 cores busy (17.9 s of CPU over 11.7 s of stepping, bench_critical_path) but waits
    on its round trips, so two of them overlap well: six 100 s paper runs over Zenoh on 2 cores took 22.2-22.5 s two
    at a time against 25.4-25.7 s one at a time."""
    return max(1, cores)


def local_jobs(jobs: int | None) -> int:
    """The local processes a sweep runs at once: jobs, or default_jobs for the cores this process may use."""
    from supervisor.engine.hosting import cores

    return jobs if jobs is not None else default_jobs(cores())


@dataclass(frozen=True, slots=True)
class Cluster:
    """Where a cluster sweep sends its runs: a Dask scheduler's address, and how long to wait for it to answer or,
    when it has no worker, for one to join."""

    address: str
    timeout: float


def grid(params: Sequence[Param], seeds: int, first_seed: int = 0) -> list[RunSpec]:
    combos = product(*[[(p.key, v) for v in p.values] for p in params])
    return [RunSpec(tuple(combo), first_seed + s) for combo in combos for s in range(seeds)]


def sweep(
    scenario_path: Path,
    params: Sequence[Param],
    seeds: int,
    jobs: int | None,
    out_dir: Path,
    engine: str = "inprocess",
    progress: Callable[[int, int], None] | None = None,
    cluster: Cluster | None = None,
    logs: bool = False,
) -> list[dict[str, Any]]:
    """Run (or resume) the whole sweep; every row, in grid order. progress(runs done, runs in all), if given, before
    the first run and after each (a batch's runs end together). cluster: the runs go to a Dask scheduler
    (supervisor.tools.sweep_cluster), else to local_jobs(jobs) local processes; either way the rows (logs: and each
    run's log, runs/<id>.mcap) come back and are written here, so resuming works alike (a run without its log, when
    logs are kept, runs again)."""
    sizes = _check_values(scenario_path, params)
    scenario_bytes = scenario_path.read_bytes()
    specs = grid(params, seeds)
    runs_dir = out_dir / "runs"
    digest = _own_runs(runs_dir, scenario_bytes)
    tell = progress or (lambda done, total: None)
    with _executor(local_jobs(jobs), cluster) as (submit, watch):  # no cluster to reach: nothing written
        _claim(runs_dir, digest)
        todo = [s for s in specs if not _done(runs_dir, s, logs)]
        done = len(specs) - len(todo)
        tell(done, len(specs))
        workers = 0 if cluster is not None else local_jobs(jobs)
        futures = _submitted(submit, scenario_path, scenario_bytes, todo, engine, logs, workers, sizes)
        failed: list[str] = []  # a run that fails is a result too: the others go on (a new user lost a batch's rows)
        try:
            for spec, outcome in _finished(futures, watch):  # a batch's failures after its rows: all are kept
                failed += _keep(runs_dir, spec, outcome, logs)
                done += 1
                tell(done, len(specs))
        finally:  # Ctrl-C, a lost cluster: a Dask client's runs not started are not (it would wait for them); local
            for future in futures if cluster is not None else ():  # ones end with their workers (no InvalidStateError)
                future.cancel()
    return _results(runs_dir, specs, out_dir, failed)


def _results(runs_dir: Path, specs: list[RunSpec], out_dir: Path, failed: list[str]) -> list[dict[str, Any]]:
    """Every row, in grid order, also to results.csv; SimulationError naming the first failed run if any failed (the
    rows of the others written all the same; a rerun of the sweep runs the failed ones again)."""
    rows = [json.loads(path.read_text()) for s in specs if (path := runs_dir / f"{s.run_id}.json").exists()]
    write_csv(rows, out_dir / "results.csv")
    if failed:
        also, kept = f"; {len(failed) - 1} more failed" if len(failed) > 1 else "", f"the {len(rows)} runs that ended"
        raise SimulationError(f"{failed[0]}{also} (results.csv holds {kept}; a rerun runs the failed ones again)")
    return rows


def _submitted(
    submit: Submit, scenario_path: Path, scenario_bytes: bytes, todo: list[RunSpec], engine: str, logs: bool, jobs: int,
    sizes: tuple[int, int],
) -> dict[Future[Any], list[RunSpec]]:  # fmt: skip
    """The runs sent where they run, each future with its runs: in batches stepped together (sweep_runs.run_many)
    on the in-process engine for jobs local workers (sizes: the least and most steps x vehicles the swept values
    make); one at a time with logs, on the Zenoh engine (whose runs are processes of their own) or on a cluster
    (jobs 0: its workers may be many, and come and go)."""
    name = scenario_path.name
    if not jobs or logs or engine != "inprocess":
        work = run_logged if logs else run_one
        return {submit(work, name, scenario_bytes, spec, engine): [spec] for spec in todo}
    least, largest = sizes
    per_worker = 1 if least == largest or jobs == 1 else BATCHES_PER_WORKER
    parts = batches(todo, jobs, batch_limit(largest), per_worker)
    return {submit(run_many, name, scenario_bytes, batch): batch for batch in parts}


def batches(todo: Sequence[RunSpec], jobs: int, most: int = MAX_BATCH, per_worker: int = 1) -> list[list[RunSpec]]:
    """todo in order, in batches of at most `most` runs whose sizes differ by one at most, a multiple of jobs of
    them, at least per_worker each, unless there are fewer runs."""
    count = min(len(todo), jobs * max(per_worker, math.ceil(len(todo) / (jobs * most))))
    size, extra = divmod(len(todo), max(1, count))
    bounds = [n * size + min(n, extra) for n in range(count + 1)]
    return [list(todo[a:b]) for a, b in pairwise(bounds)]


def _finished(
    futures: dict[Future[Any], list[RunSpec]], watch: Callable[[], None] | None
) -> Iterator[tuple[RunSpec, Any]]:
    """Each run with its outcome, as their futures finish."""
    for future in _completed(futures, watch):
        outcomes = _outcomes(futures[future], future)
        yield from sorted(outcomes, key=lambda outcome: isinstance(outcome[1], Exception))


def _outcomes(specs: list[RunSpec], future: Future[Any]) -> list[tuple[RunSpec, Any]]:
    """Each run's outcome (its row, run_logged's (row, log), or the exception that ended it); a future that failed
    as a whole (a worker lost) is every run's failure."""
    try:
        value = future.result()
    except Exception as exc:
        return [(spec, exc) for spec in specs]
    return list(zip(specs, value if isinstance(value, list) else [value], strict=True))  # run_many's list, else one


def _check_values(scenario_path: Path, params: Sequence[Param]) -> tuple[int, int]:
    """Every value must make a valid scenario, alone or with values of the other params (a loss model's options
    need the model swept with them): ScenarioError, its own, before anything runs. The least and the most steps x
    vehicles of the values (of the scenario, if nothing is swept: how to batch, _submitted)."""
    from supervisor.config.derived import steps_of
    from supervisor.config.scenario import load_scenario

    variants = [load_scenario(scenario_path)]
    variants += [_valid_with(scenario_path, params, n, value) for n, p in enumerate(params) for value in p.values]
    sizes = [steps_of(sc) * len(sc.vehicle_ids) for sc in variants[1:] or variants]  # the scenario's own, if unswept
    return min(sizes), max(sizes)


def _valid_with(scenario_path: Path, params: Sequence[Param], n: int, value: Any) -> Scenario:
    """The scenario with params[n] = value alone, else with the first combination of the other params' values it
    is valid with (at most COMBINATIONS_TRIED of them); if none, the ScenarioError of the first combination (the
    one that says most: a loss model's option out of range rather than options without a model)."""
    from supervisor.config.scenario import load_scenario

    setting = override(params[n].key, value)
    try:
        return load_scenario(scenario_path, [setting])
    except ScenarioError as alone:
        first: ScenarioError | None = None
        others = [[override(p.key, v) for v in p.values] for m, p in enumerate(params) if m != n]
        for combo in islice(product(*others), COMBINATIONS_TRIED) if others else ():
            try:  # in the params' order, as a run applies them (a table, then one of its keys, is not the reverse)
                return load_scenario(scenario_path, [*combo[:n], setting, *combo[n:]])
            except ScenarioError as exc:
                first = first or exc
        raise (first or alone) from None


Submit = Callable[..., Future[Any]]  # submit(work, *args): work(*args) where the runs go


@contextlib.contextmanager
def _executor(jobs: int, cluster: Cluster | None) -> Iterator[tuple[Submit, Callable[[], None] | None]]:
    """Where the runs go (jobs local processes, each started by _worker_start and running through _in_worker: it
    ends with the sweep; or a Dask cluster), and what to check while waiting for them (None: nothing)."""
    if cluster is None:
        with ProcessPoolExecutor(max_workers=max(1, jobs), initializer=_worker_start, initargs=(os.getpid(),)) as pool:

            def submit(work: Callable[..., Any], *args: Any) -> Future[Any]:
                return pool.submit(_in_worker, work, *args)

            try:
                yield submit, None
            except BaseException:
                _stop_workers(pool)
                raise
        return
    from supervisor.tools.sweep_cluster import cluster_executor

    with cluster_executor(cluster.address, cluster.timeout) as (remote, watch):
        yield remote.submit, watch.watch


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """The sweep stops (Ctrl-C of cpf alone, SIGTERM, a notebook's interrupt, a failed run): each worker is sent
    SIGTERM, so that its batch ends at its next step (_worker_start, _in_worker), not when its last run does; the pool
    waited for that, up to a whole batch's runs (the review measured 42-48 s), and nothing of it was kept. The pool's
    processes are not public before Python 3.14 (terminate_workers)."""
    processes = getattr(pool, "_processes", None) or {}
    for process in list(processes.values()):
        with contextlib.suppress(OSError, ValueError):  # already gone, or closed
            process.terminate()


def _worker_start(parent: int) -> None:
    """A local worker ends with its sweep: were cpf killed (SIGKILL: none of its own cleanup runs), the kernel sends
    the worker SIGTERM, which ends its run as a Ctrl-C of `cpf run` does (cpf's handler, set here also for a sweep
    from Python, cpf.sweep, whose process has none: the run's own processes stopped, its temporary directory
    removed), and _in_worker then ends the worker; without both it ran on through the runs queued for it, an
    orphan."""
    signal.signal(signal.SIGTERM, _worker_signal)
    collector.pace()  # the worker is the sweep's to its end (cpf.sweep's too, whose own process is the user's)
    if set_parent_death_signal(signal.SIGTERM) and os.getppid() != parent:
        os._exit(ORPHANED)  # the sweep died before the prctl: the signal would never come


def _worker_signal(signum: int, frame: FrameType | None) -> None:
    """A worker's SIGTERM: a run under way stops at its next step (cpf's handler: it cleans up, then _in_worker
    ends the worker); a worker waiting for work ends at once, quietly (raised in the pool's loop, the stop printed
    a traceback to the sweep's terminal)."""
    from supervisor.engine import interrupts

    if interrupts.running():
        interrupts.handle(signum, frame)
    else:
        os._exit(ORPHANED)


def _completed(futures: Iterable[Future[Any]], watch: Callable[[], None] | None) -> Iterator[Any]:
    """The futures as they finish; watch() every WATCH_INTERVAL s while none does."""
    pending = set(futures)
    while pending:
        finished, pending = wait(pending, None if watch is None else WATCH_INTERVAL, FIRST_COMPLETED)
        if not finished and watch is not None:
            watch()
        yield from finished


def _in_worker(work: Callable[..., Any], *args: Any) -> Any:
    """work(*args) in a local worker, which ends (instead of taking the next run queued for it) once a stop was asked
    for during the run: the sweep's SIGTERM when it died (_worker_start) or a Ctrl-C, however the run then ended.
    The run has cleaned up on its way here. The whole run is deferred (interrupts): raised while the run started,
    before its engine's safe points, a library swallowed the stop and the run went on; and cpf's handler raises
    once, so a worker whose stop ended otherwise waited for work for ever (seen). (Not by asking whether the parent
    is gone: its main thread's death sends the signal while the rest of it goes on, and getppid() still names it.)"""
    from supervisor.engine import interrupts

    try:
        with interrupts.deferred():
            return work(*args)
    except KeyboardInterrupt:
        os._exit(ORPHANED)
    finally:
        if interrupts.stopping():
            os._exit(ORPHANED)


def _own_runs(runs_dir: Path, scenario_bytes: bytes) -> str:
    """The scenario's digest; ScenarioError if runs_dir holds the rows of another scenario, or of this file before
    an edit (a run's id names its settings and seed only, and a resumed sweep takes every row it finds: it gave
    another scenario's numbers as this one's)."""
    digest = hashlib.sha256(scenario_bytes).hexdigest()
    marker = runs_dir / SCENARIO_DIGEST
    if marker.exists():
        if marker.read_text(encoding="utf-8", errors="replace").strip() == digest:
            return digest
        whose = "the runs of another scenario, or of this file before an edit"
    elif any(runs_dir.glob("*.json")):
        whose = "runs of a sweep that did not record its scenario"
    else:
        return digest
    raise ScenarioError(
        f"--out: {runs_dir.parent} holds {whose} (a sweep resumes only its own): give another --out, or remove "
        f"{runs_dir}"
    )


def _claim(runs_dir: Path, digest: str) -> None:
    """runs_dir made, with the digest of the scenario whose runs it holds (_own_runs)."""
    runs_dir.mkdir(parents=True, exist_ok=True)
    if not (runs_dir / SCENARIO_DIGEST).exists():
        _write_whole(runs_dir / SCENARIO_DIGEST, digest.encode())


def _done(runs_dir: Path, spec: RunSpec, logs: bool) -> bool:
    """Whether a resumed sweep has this run already: its row, and its log if logs are kept."""
    return (runs_dir / f"{spec.run_id}.json").exists() and (not logs or (runs_dir / f"{spec.run_id}.mcap").exists())


def _keep(runs_dir: Path, spec: RunSpec, done: Any, logs: bool) -> list[str]:
    """A finished run's row to runs_dir/<id>.json, its log (run_logged) first to runs_dir/<id>.mcap (named in the
    row's "log"), each whole or not at all (a resumed sweep trusts every file there); [] then, or, if it failed
    (done: its exception), the line naming it."""
    if isinstance(done, CancelledError):  # not by us: a Dask client cancels its futures when it loses the scheduler
        raise SimulationError(f"sweep run {spec.run_id} was cancelled (Dask scheduler lost?)") from None
    if isinstance(done, Exception):
        return [f"sweep run {spec.run_id} failed: {done}"]
    row, log = done if logs else (done, None)  # run_logged's (row, log), or run_one's row
    if log is not None:  # the row says where its log is (relative to the sweep's directory)
        _write_whole(runs_dir / f"{spec.run_id}.mcap", log)
        row = {**row, "log": f"{runs_dir.name}/{spec.run_id}.mcap"}
    _write_whole(runs_dir / f"{spec.run_id}.json", json.dumps(row).encode())
    return []


def _write_whole(path: Path, data: bytes) -> None:
    part = path.with_name(path.name + ".part")
    part.write_bytes(data)
    part.replace(path)


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    columns = list(dict.fromkeys(key for row in rows for key in row))
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)

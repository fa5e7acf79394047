"""A sweep's runs, wherever they run (a local worker process, a Dask worker): one run (run_one, run_logged), or many
at once (run_many: the in-process engine's runs stepped together, supervisor.engine.batch), each giving its metrics
row. The scenario comes as the file's bytes and is written into the run's temporary directory under its own name
(the Zenoh engine's processes load it from there).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import tempfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from supervisor.analysis.metrics import steady_error
from supervisor.analysis.summary import coordination_error, nan_max
from supervisor.config.toml_writer import toml_value

if TYPE_CHECKING:
    from supervisor.config.scenario_schema import Scenario
    from supervisor.errors import ScenarioError


# Runs stepped together at most (run_many): the vehicles' lanes cost less per vehicle up to a few hundred lanes
# (vehicles.lanes), while a batch is written, shown and resumed only whole.
MAX_BATCH = 64
# Bytes the series of a batch's runs may hold together (a worker holds them all until the batch ends): fewer runs a
# batch for long runs of large fleets (a 1 h run of 50 AUVs at 0.1 s holds ~200 MB), one-at-a-time's footprint per run.
BATCH_MEMORY = 1 << 30


@dataclass(frozen=True, slots=True)
class RunSpec:
    settings: tuple[tuple[str, Any], ...]
    seed: int

    @property
    def run_id(self) -> str:
        text = json.dumps([list(self.settings), self.seed])
        readable = "_".join(f"{k.split('.')[-1]}={v}" for k, v in self.settings)
        return f"{readable}_seed={self.seed}_{hashlib.sha1(text.encode()).hexdigest()[:8]}".replace("/", "-")

    @property
    def overrides(self) -> tuple[str, ...]:
        return tuple(override(k, v) for k, v in self.settings)


def override(key: str, value: Any) -> str:
    """key=value as --set takes it: value written as TOML (a table as an inline table, which JSON's braces are not:
    `--param 'comms.loss_model_options={p=0.1},{p=0.2}'` was refused as "must be a table")."""
    return f"{key}={toml_value(value)}"


def run_one(scenario_name: str, scenario_bytes: bytes, spec: RunSpec, engine: str) -> dict[str, Any]:
    """One run of the sweep: its metrics row, nothing recorded (the in-process engine counts the messages a log would
    hold; the Zenoh engine's log is deleted)."""
    return _measured(scenario_name, scenario_bytes, spec, engine, False)[0]


def run_logged(scenario_name: str, scenario_bytes: bytes, spec: RunSpec, engine: str) -> tuple[dict[str, Any], bytes]:
    """run_one, and the run's whole log (with its Foxglove scene) as bytes: `cpf sweep --logs`. Bytes, not a path: a
    cluster's workers share no filesystem with the client, which writes the log where the row goes."""
    row, log = _measured(scenario_name, scenario_bytes, spec, engine, True)
    assert log is not None
    return row, log


def run_many(scenario_name: str, scenario_bytes: bytes, specs: Sequence[RunSpec]) -> list[dict[str, Any] | Exception]:
    """Each spec's row (or what ended its run: a scenario its settings make invalid included), the runs stepped
    together on the in-process engine, nothing recorded (supervisor.engine.batch: their alike vehicles as lanes);
    each row that of run_one but its wall_s, the batch's shared equally."""
    from supervisor.engine.batch import BatchRun, run_batch

    with _scenario_file(scenario_name, scenario_bytes) as path:
        text = path.read_text(encoding="utf-8")
        loaded = [_loaded(path, spec) for spec in specs]
        valid = [(spec, sc) for spec, sc in zip(specs, loaded, strict=True) if not isinstance(sc, Exception)]
        runs = [BatchRun(sc, str(path), text, spec.seed) for spec, sc in valid]
        results = iter([result for part in _within_memory(runs) for result in run_batch(part)])
    outcomes: list[dict[str, Any] | Exception] = []
    for spec, sc in zip(specs, loaded, strict=True):
        if isinstance(sc, Exception):
            outcomes.append(sc)
            continue
        outcomes.append(_row(spec, sc, next(results)))
    return outcomes


def _row(spec: RunSpec, scenario: Scenario, result: Any) -> dict[str, Any] | Exception:
    """run_one's row of a finished run, or what ended it (the summary's failure included: this run's alone)."""
    if isinstance(result, Exception):
        return result
    try:
        return row_of(spec, scenario, result)
    except Exception as exc:
        return exc


def batch_limit(vehicle_steps: int) -> int:
    """The runs a batch may hold: MAX_BATCH, fewer where runs of vehicle_steps (steps x vehicles) would hold more
    than BATCH_MEMORY of series together; one at least."""
    from supervisor.analysis.series import BYTES_PER_VEHICLE_STEP

    return max(1, min(MAX_BATCH, BATCH_MEMORY // max(1, vehicle_steps * BYTES_PER_VEHICLE_STEP)))


def _within_memory(runs: Sequence[Any]) -> list[list[Any]]:
    """runs (BatchRun) in order, in parts that each hold at most batch_limit of its largest run: the sweep sizes
    its batches from each swept value alone, and only here are the runs' own steps and vehicles known (a longer
    duration with a shorter step can make a run many times the largest the sweep saw)."""
    from supervisor.config.derived import steps_of

    parts: list[list[Any]] = []
    largest = 0
    for run in runs:
        size = steps_of(run.scenario) * len(run.scenario.vehicle_ids)
        if parts and len(parts[-1]) < batch_limit(max(largest, size)):
            parts[-1].append(run)
            largest = max(largest, size)
        else:
            parts.append([run])
            largest = size
    return parts


def _loaded(path: Path, spec: RunSpec) -> Scenario | ScenarioError:
    """The spec's scenario, or the ScenarioError its settings give (the sweep checks each swept value, alone or in
    some combination, not every combination: sweep._check_values)."""
    from supervisor.errors import ScenarioError

    try:
        return _load(path, spec)
    except ScenarioError as exc:
        return exc


def _load(path: Path, spec: RunSpec) -> Scenario:
    """load_scenario of the spec; its ScenarioError names the file by its name (paper.toml), not by the temporary
    copy a user never saw."""
    from supervisor.config.scenario import load_scenario
    from supervisor.errors import ScenarioError

    try:
        return load_scenario(path, spec.overrides)
    except ScenarioError as exc:
        here = str(path)
        raise ScenarioError(
            str(exc).replace(here, path.name), [e.replace(here, path.name) for e in exc.errors]
        ) from None


@contextlib.contextmanager
def _scenario_file(scenario_name: str, scenario_bytes: bytes) -> Iterator[Path]:
    """The scenario file written under its own name in a temporary directory (its parent, with room for a log)."""
    with tempfile.TemporaryDirectory(prefix="cpf-sweep-") as tmp:
        path = Path(tmp, "scenario")
        path.mkdir()
        path = path / scenario_name
        path.write_bytes(scenario_bytes)
        yield path


def _measured(
    scenario_name: str, scenario_bytes: bytes, spec: RunSpec, engine: str, keep_log: bool
) -> tuple[dict[str, Any], bytes | None]:
    """The run's row, and its log if keep_log."""
    from supervisor.engine.progress import Progress

    with _scenario_file(scenario_name, scenario_bytes) as path:
        scenario = _load(path, spec)
        quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
        out = path.parent.parent / "run.mcap"
        result = _run(engine, scenario, path, spec.overrides, out, spec.seed, quiet, keep_log)
        log = out.read_bytes() if keep_log else None
    return row_of(spec, scenario, result), log


def _run(
    engine: str, scenario: Any, path: Path, overrides: tuple[str, ...], out: Path, seed: int, quiet: Any, log: bool
) -> Any:
    """The run on either engine, its log written to out only if log; the Zenoh engine's processes load the scenario
    file themselves, with overrides."""
    text = path.read_text(encoding="utf-8")
    if engine == "zenoh":
        from supervisor.engine.cosim import BusOptions, run_zenoh

        bus = BusOptions(overrides=overrides)  # a log not kept is deleted once its metrics are taken: no scene
        return run_zenoh(scenario, path, text, out, seed, "lockstep", 1.0, bus, quiet, scene=log)
    from supervisor.engine.inprocess import run_inprocess

    return run_inprocess(scenario, str(path), text, out if log else None, seed, quiet)


def row_of(spec: RunSpec, scenario: Any, result: Any) -> dict[str, Any]:
    """A run's row: its settings and seed, then what the sweep measures of it."""
    from supervisor.analysis.summary import summarize
    from supervisor.config.derived import intervals, tube_radius

    rep = scenario.report
    tube = tube_radius(scenario)
    summary = summarize(
        result.series, scenario.scenario.duration, intervals(scenario), rep.transient, tube, rep.coordination_tolerance
    )
    return {**dict(spec.settings), "seed": spec.seed, **_measures(result, summary, scenario)}


class _Run(NamedTuple):
    """What a row's measures are taken from: the run, its summary and scenario, and its coordination error."""

    result: Any
    summary: Any
    scenario: Any
    coordination: Any  # max_ij |gamma_i - gamma_j| at each step
    settled: Any  # the steps after the transient: none if the run ends within it (its measures then NaN, as the
    # summary's path error: it was the last sample's, below the steady error of the samples before it)


# What the sweep measures of a run, in its row's order: each measure's column type and how it is taken. float: a real
# number, None (sync_time, resync_time: never settled, or no fault to settle after) or NaN where a run gives none, a
# float column of a table of rows (cpf.sweep); int: packets counted.
_MEASURES: dict[str, tuple[type, Callable[[_Run], Any]]] = {
    "steady_coordination_error": (float, lambda r: steady_error(r.result.series.t, r.coordination,
                                                                r.scenario.report.transient)[0]),  # the report's
    "peak_coordination_error_after_transient": (float, lambda r: nan_max(r.coordination[r.settled])),
    "sync_time": (float, lambda r: r.summary.sync_time),
    "resync_time": (float, lambda r: r.summary.resync_time),
    "max_path_error": (float, lambda r: r.summary.max_path_error_after_transient),
    "sent": (int, lambda r: r.result.link_counts["sent"]),
    "delivered": (int, lambda r: r.result.link_counts["delivered"]),
    "dropped": (int, lambda r: r.result.link_counts["dropped"]),
    "wall_s": (float, lambda r: r.result.wall_time),
}  # fmt: skip
FLOAT_MEASURES = tuple(name for name, (kind, _) in _MEASURES.items() if kind is float)


def _measures(result: Any, summary: Any, scenario: Any) -> dict[str, Any]:
    series = result.series
    run = _Run(result, summary, scenario, coordination_error(series.gamma), series.t >= scenario.report.transient)
    return {name: take(run) for name, (_, take) in _MEASURES.items()}

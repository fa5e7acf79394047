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
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from supervisor.analysis.metrics import STEADY_STATE_WINDOW
from supervisor.analysis.summary import coordination_error

if TYPE_CHECKING:
    from supervisor.config.scenario_schema import Scenario
    from supervisor.errors import ScenarioError


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
    return f"{key}={json.dumps(value)}"


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
        results = iter(run_batch(runs))
    outcomes: list[dict[str, Any] | Exception] = []
    for spec, sc in zip(specs, loaded, strict=True):
        if isinstance(sc, Exception):
            outcomes.append(sc)
            continue
        result = next(results)
        outcomes.append(result if isinstance(result, Exception) else row_of(spec, sc, result))
    return outcomes


def _loaded(path: Path, spec: RunSpec) -> Scenario | ScenarioError:
    """The spec's scenario, or the ScenarioError its settings give (swept values are checked one by one, not every
    combination)."""
    from supervisor.errors import ScenarioError

    try:
        return _load(path, spec)
    except ScenarioError as exc:
        return exc


def _load(path: Path, spec: RunSpec) -> Scenario:
    """load_scenario of the spec; its ScenarioError names the file as the sweep was given it (its name), not the
    temporary copy a user never saw."""
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


def _measures(result: Any, summary: Any, scenario: Any) -> dict[str, Any]:
    series = result.series
    coordination = coordination_error(series.gamma)
    tail = series.t >= series.t[-1] - STEADY_STATE_WINDOW
    settled = series.t >= min(scenario.report.transient, series.t[-1])
    return {
        "steady_coordination_error": float(coordination[tail].max()),
        "peak_coordination_error_after_transient": float(coordination[settled].max()),
        "sync_time": summary.sync_time,
        "resync_time": summary.resync_time,
        "max_path_error": summary.max_path_error_after_transient,
        "sent": result.link_counts["sent"],
        "delivered": result.link_counts["delivered"],
        "dropped": result.link_counts["dropped"],
        "wall_s": result.wall_time,
    }

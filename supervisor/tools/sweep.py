"""Monte-Carlo robustness sweeps: one scenario over a grid of parameter values and seeds.

`cpf sweep SCENARIO --param comms.loss=0,0.1,0.2 [--param ...] --seeds 20 --jobs N --out DIR` runs every
combination (each with its own seed), one process per job. Every finished run leaves DIR/runs/<id>.json, so an
interrupted sweep resumes where it stopped. Results: DIR/results.csv (one row per run) and, per swept parameter, a
plot of the steady-state coordination error and the packets sent and delivered against it, with the spread across
seeds. Steady state: the largest max|gamma_i - gamma_j| over the final STEADY_STATE_WINDOW seconds of a run.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import tempfile
import tomllib
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from typing import Any

from supervisor.analysis.metrics import STEADY_STATE_WINDOW
from supervisor.analysis.summary import coordination_error
from supervisor.config.scenario import split_outside_brackets
from supervisor.errors import ScenarioError, SimulationError


@dataclass(frozen=True, slots=True)
class Param:
    key: str
    values: tuple[Any, ...]


@dataclass(frozen=True, slots=True)
class RunSpec:
    settings: tuple[tuple[str, Any], ...]
    seed: int

    @property
    def run_id(self) -> str:
        text = json.dumps([list(self.settings), self.seed])
        readable = "_".join(f"{k.split('.')[-1]}={v}" for k, v in self.settings)
        return f"{readable}_seed={self.seed}_{hashlib.sha1(text.encode()).hexdigest()[:8]}".replace("/", "-")


def parse_param(text: str) -> Param:
    """KEY=v1,v2,... (TOML values; commas inside brackets belong to a value, so graphs can be swept:
    graph.edges=[[1,2],[1,3]],[[1,2],[2,3]]) or KEY=start:stop:step (inclusive of stop, within rounding)."""
    key, sep, spec = text.partition("=")
    if not sep or not key.strip() or not spec.strip():
        raise ScenarioError(f"--param: expected KEY=v1,v2,... or KEY=start:stop:step, got {text!r}")
    if spec.count(":") == 2:
        start, stop, step = (_value(part, text) for part in spec.split(":"))
        if not all(isinstance(v, int | float) for v in (start, stop, step)) or step <= 0:
            raise ScenarioError(f"--param {key}: start:stop:step needs numbers and step > 0, got {spec!r}")
        count = math.floor((stop - start) / step + 1e-9) + 1
        return Param(key.strip(), tuple(round(start + i * step, 12) for i in range(count)))
    return Param(key.strip(), tuple(_value(part, text) for part in split_outside_brackets(spec)))


def _value(text: str, whole: str) -> Any:
    try:
        return tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        raise ScenarioError(f"--param: {text.strip()!r} is not a TOML value, in {whole!r}") from None


def grid(params: Sequence[Param], seeds: int, first_seed: int = 0) -> list[RunSpec]:
    combos = product(*[[(p.key, v) for v in p.values] for p in params])
    return [RunSpec(tuple(combo), first_seed + s) for combo in combos for s in range(seeds)]


def _override(key: str, value: Any) -> str:
    return f"{key}={json.dumps(value)}"


def run_one(scenario_path: str, spec: RunSpec, runs_dir: str, engine: str) -> dict[str, Any]:
    """One run of the sweep (in a worker process): its metrics row, also written to runs_dir/<id>.json."""
    from supervisor.analysis.summary import summarize
    from supervisor.config.derived import intervals, tube_radius
    from supervisor.config.scenario import load_scenario
    from supervisor.engine.progress import Progress

    overrides = tuple(_override(k, v) for k, v in spec.settings)
    scenario = load_scenario(Path(scenario_path), overrides)
    quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
    with tempfile.TemporaryDirectory(prefix="cpf-sweep-") as tmp:
        result = _run(engine, scenario, Path(scenario_path), overrides, Path(tmp) / "run.mcap", spec.seed, quiet)
    rep = scenario.report
    tube = tube_radius(scenario)
    summary = summarize(
        result.series, scenario.scenario.duration, intervals(scenario), rep.transient, tube, rep.coordination_tolerance
    )
    row = {**dict(spec.settings), "seed": spec.seed, **_measures(result, summary, scenario)}
    Path(runs_dir, f"{spec.run_id}.json").write_text(json.dumps(row))
    return row


def _run(engine: str, scenario: Any, path: Path, overrides: tuple[str, ...], out: Path, seed: int, quiet: Any) -> Any:
    """The run on either engine; the Zenoh engine's processes load the scenario file themselves, with overrides."""
    text = path.read_text(encoding="utf-8")
    if engine == "zenoh":
        from supervisor.engine.cosim import BusOptions, run_zenoh

        bus = BusOptions(overrides=overrides)  # its log is deleted once its metrics are taken: no scene to build
        return run_zenoh(scenario, path, text, out, seed, "lockstep", 1.0, bus, quiet, scene=False)
    from supervisor.engine.inprocess import run_inprocess

    return run_inprocess(scenario, str(path), text, None, seed, quiet)  # its log would be deleted unread


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


def sweep(
    scenario_path: Path,
    params: Sequence[Param],
    seeds: int,
    jobs: int,
    out_dir: Path,
    engine: str = "inprocess",
    progress: Callable[[int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """Run (or resume) the whole sweep; returns every row, in grid order. progress, if given, is called with (runs
    done, runs in all) before the first run and after each (the command line draws a bar with it)."""
    from supervisor.config.scenario import load_scenario

    for param in params:  # every value must make a valid scenario: fail before running anything
        for value in param.values:
            load_scenario(scenario_path, [_override(param.key, value)])
    runs_dir = out_dir / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    specs = grid(params, seeds)
    todo = [s for s in specs if not (runs_dir / f"{s.run_id}.json").exists()]
    done = len(specs) - len(todo)
    if progress is not None:
        progress(done, len(specs))
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = {pool.submit(run_one, str(scenario_path), s, str(runs_dir), engine): s for s in todo}
        for future in as_completed(futures):
            try:
                future.result()
            except Exception as exc:  # one failed run stops the sweep with its name; finished runs are kept
                for other in futures:
                    other.cancel()
                raise SimulationError(f"sweep run {futures[future].run_id} failed: {exc}") from exc
            done += 1
            if progress is not None:
                progress(done, len(specs))
    rows = [json.loads((runs_dir / f"{s.run_id}.json").read_text()) for s in specs]
    write_csv(rows, out_dir / "results.csv")
    return rows


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    columns = list(dict.fromkeys(key for row in rows for key in row))
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)

"""cpf.run, cpf.load, cpf.sweep: the command line's `cpf run` and `cpf sweep` from Python, results as a Run or a
pandas DataFrame.

Each builds the arguments the command line would get and goes through its own code: the same parser (options checked
and defaulted alike; a bad one raises ScenarioError with argparse's message), `cpf run`'s execute
(supervisor.cli.run: checks, either engine, the log) and `cpf sweep`'s sweep (supervisor.tools.sweep). Nothing is
printed: the progress line (or bar) goes to stderr, unless progress=False, and errors are raised.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cpf.inputs import Changes, Scenario, fault_specs, overrides, param_specs, path_of, run_options, scenario_file
from cpf.runs import Run

if TYPE_CHECKING:
    import pandas as pd


def run(
    scenario: Scenario,
    engine: str = "inprocess",
    set: Changes = None,  # the command line's name (--set), though it shadows the builtin here
    faults: Sequence[str | Mapping[str, Any]] | None = None,
    seed: int | None = None,
    out: str | Path | None = None,
    progress: bool = True,
    options: Sequence[str] = (),
) -> Run:
    """Run a scenario as `cpf run` does and return the run (its log read when a table is first asked for).

    scenario: a path, TOML text (a str with a line break) or a dict of the file's tables; engine: "inprocess" or
    "zenoh"; set: {"comms.loss": 0.2} or ["comms.loss=0.2"] (--set); faults: specs as --fault takes them, or dicts;
    seed: --seed; out: the log (None: a temporary file, deleted with the Run); options: any other `cpf run` option,
    as on the command line (["--no-foxglove", "--max-window", "10"]; ["--metrics", FILE] writes its metrics file).
    ScenarioError for bad input, SimulationError (or FloatingPointError, for a diverging vehicle) for a run that
    failed."""
    keep = Path(tempfile.mkdtemp(prefix="cpf-run-"))
    try:
        path = scenario_file(scenario, keep)
        log = keep / "run.mcap" if out is None else path_of(out, "out", ", or None")
        argv = ["--engine", engine, "--out", str(log), *run_options(options)]
        argv += [f"--set={text}" for text in overrides(set)] + [f"--fault={spec}" for spec in fault_specs(faults)]
        argv += ([] if seed is None else ["--seed", str(seed)]) + ([] if progress else ["--quiet"])
        _execute([*argv, "--", str(path)])  # --: a file named -x.toml is a file
    except BaseException:
        shutil.rmtree(keep, ignore_errors=True)
        raise
    if out is not None and path.parent != keep:  # nothing of the run in it
        shutil.rmtree(keep, ignore_errors=True)
        return Run(log)
    return Run(log, keep)


def _execute(argv: list[str]) -> None:
    """`cpf run` with these arguments, through its own parser and code, but for what it prints: the progress as a
    tqdm.auto bar, and --metrics (in options) written as `cpf run --metrics` writes it."""
    from supervisor.cli.parser import arguments
    from supervisor.cli.run import execute
    from supervisor.cli.run_report import write_metrics
    from supervisor.collector import paced

    parsed = arguments(["run", *argv])
    parsed.bar = True  # progress as a tqdm.auto bar (text; a notebook's widget needs ipywidgets, not ours)
    with paced():
        checked, result, _ = execute(parsed)
    if parsed.metrics:  # the summary is not printed, its numbers are in Run.summary
        write_metrics(parsed.metrics, checked, result)


def load(path: str | Path) -> Run:
    """A run from a log `cpf run` wrote; LogError (a ScenarioError) for one that is missing, not a log, cut short
    (`cpf recover` it first) or damaged. Its tables are read when first asked for."""
    from supervisor.errors import LogError
    from supervisor.record.logfile import verify

    log = path_of(path, "path", " of a log", LogError)
    verify(log)
    return Run(log)


def sweep(
    scenario: Scenario,
    params: Mapping[str, Any],
    seeds: int = 2,
    jobs: int | None = None,
    out: str | Path | None = None,
    engine: str = "inprocess",
    progress: bool = True,
    logs: bool = False,
) -> pd.DataFrame:
    """`cpf sweep`: every combination of params ({"coordination.k": [0.1, 0.2]}, {"comms.loss": "0:0.8:0.1"} as --param
    takes it, or one value) times seeds 0..seeds-1, jobs runs at once (None: one per core, as `cpf sweep`); the rows of
    its results.csv, in grid order. out: the sweep's directory (runs/, results.csv; resumable), None: a temporary one.
    A progress bar (tqdm.auto, on stderr) unless progress=False. logs: each run's log kept as out/runs/<id>.mcap (`cpf
    sweep --logs`; cpf.load reads one); without, runs record only their rows."""
    from supervisor.cli.commands import sweep_params
    from supervisor.cli.parser import arguments
    from supervisor.cli.terminal import SweepBar
    from supervisor.errors import ScenarioError
    from supervisor.tools.sweep import sweep as run_sweep

    if logs and out is None:  # a temporary directory would take the logs with it
        raise ScenarioError("sweep: logs=True keeps each run's log in out/runs/: give out a directory")

    with tempfile.TemporaryDirectory(prefix="cpf-sweep-") as tmp:
        path = scenario_file(scenario, Path(tmp))
        argv = ["sweep", "--seeds", str(seeds), "--engine", engine, *(["--logs"] if logs else [])]
        argv += [] if jobs is None else ["--jobs", str(jobs)]
        argv += ["--out", str(Path(tmp) / "sweep" if out is None else path_of(out, "out", ", or None"))]
        args = arguments([*argv, *(f"--param={spec}" for spec in param_specs(params)), "--", str(path)])
        swept = sweep_params(args)  # checked as `cpf sweep` checks them, --out too
        bar = SweepBar(notebook=True) if progress else None
        try:
            rows = run_sweep(args.scenario, swept, args.seeds, args.jobs, args.out, args.engine, bar, logs=args.logs)
        finally:
            if bar is not None:
                bar.close()
    return _table(rows)


def _table(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """A sweep's rows as a table, the measures that are real numbers as float columns: NaN for a time never reached
    (None in a row, empty in results.csv), as pandas reads results.csv."""
    import pandas as pd

    from supervisor.tools.sweep_runs import FLOAT_MEASURES

    table = pd.DataFrame.from_records(rows, columns=list(dict.fromkeys(key for row in rows for key in row)))
    return table.astype({name: float for name in FLOAT_MEASURES if name in table.columns})

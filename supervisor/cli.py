"""The `cpf` command line. The only place that turns errors into messages and exit codes.

Exit codes: 0 success, 1 run-time failure, 2 bad input (scenario file or arguments), 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from supervisor.errors import CpfError, ScenarioError

EXIT_RUNTIME, EXIT_INPUT, EXIT_INTERRUPTED = 1, 2, 130


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="cpf", description="Coordinated path-following co-simulator for AUV fleets.")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="simulate a scenario and record it to MCAP")
    run.add_argument("scenario", type=Path, help="scenario file (TOML)")
    run.add_argument("--engine", choices=["inprocess"], default="inprocess", help="simulation engine")
    run.add_argument("--seed", type=int, default=None, help="random seed (default: the scenario's)")
    run.add_argument("--out", type=Path, default=None, help="MCAP file to write (default: runs/<name>.mcap)")
    run.add_argument("--metrics", type=Path, default=None, help="also write the summary as JSON here")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    report = sub.add_parser("report", help="figures of a recorded run")
    report.add_argument("log", type=Path, help="MCAP file written by cpf run")
    report.add_argument("--out", type=Path, default=None, help="directory for the figures (default: beside the log)")
    return parser


def _run(args: argparse.Namespace) -> int:
    from supervisor.inprocess import run_inprocess
    from supervisor.progress import Progress
    from supervisor.scenario import load_scenario
    from supervisor.summary import format_summary, summarize

    scenario = load_scenario(args.scenario)
    seed = scenario.scenario.seed if args.seed is None else args.seed
    out = args.out or Path("runs") / f"{scenario.scenario.name}.mcap"
    progress = Progress(scenario.scenario.duration, enabled=not args.quiet)
    result = run_inprocess(scenario, str(args.scenario), args.scenario.read_text(), out, seed, progress)
    faults = [(f.kind, f.start, f.end) for f in scenario.faults]
    rep = scenario.report
    tube = abs(scenario.path_following.delta) + rep.tube_margin
    summary = summarize(
        result.series, scenario.scenario.duration, faults, rep.transient, tube, rep.coordination_tolerance
    )
    factor = scenario.scenario.duration / max(result.wall_time, 1e-9)
    print(
        f"{scenario.scenario.name}: {len(scenario.vehicles)} vehicles, {scenario.scenario.duration:g} s simulated "
        f"in {result.wall_time:.2f} s ({factor:.0f}x real time), {result.messages} messages -> {out}"
    )
    print(format_summary(summary))
    if args.metrics:
        args.metrics.parent.mkdir(parents=True, exist_ok=True)
        args.metrics.write_text(json.dumps(summary.as_dict(), indent=2))
    return 0


def _report(args: argparse.Namespace) -> int:
    from supervisor.report import load_run, write_figures

    if not args.log.is_file():
        raise ScenarioError(f"{args.log}: no such log file")
    out = args.out or args.log.parent
    for path in write_figures(load_run(args.log), out):
        print(path)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return {"run": _run, "report": _report}[args.command](args)
    except ScenarioError as exc:
        print(f"cpf: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except CpfError as exc:
        print(f"cpf: error: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt:
        print("cpf: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def entry() -> None:
    """Console-script entry point."""
    sys.exit(main())


if __name__ == "__main__":
    entry()

"""The `cpf` command line. The only place that turns errors into messages and exit codes.

Exit codes: 0 success, 1 run-time failure, 2 bad input (scenario file or arguments), 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import signal
import sys
import textwrap
from collections.abc import Sequence
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from supervisor.engine import resim_settings  # light: the table only, for the help text
from supervisor.errors import CpfError, ScenarioError

if TYPE_CHECKING:
    from supervisor.config.scenario_schema import Scenario

EXIT_RUNTIME, EXIT_INPUT, EXIT_INTERRUPTED = 1, 2, 130
START_TIMEOUT = 60.0  # s: cpf run's default --start-timeout
log = logging.getLogger("cpf")


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def _ids(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(part) for part in text.split(",") if part)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated vehicle ids, got {text!r}") from None


class _Help(argparse.ArgumentDefaultsHelpFormatter):
    """--help shows every option's default, unless its help already says it or there is none worth showing."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        trivial = action.default is None or action.default is False or action.default in ([], ())
        if not action.option_strings or trivial or action.default is argparse.SUPPRESS or "default" in text:
            return action.help
        return f"{text} (default: %(default)s)"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cpf", description="Coordinated path-following co-simulator for AUV fleets.", formatter_class=_Help
    )
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="simulate a scenario and record it to MCAP")
    run.add_argument("scenario", type=Path, help="scenario file (TOML)")
    run.add_argument("--engine", choices=["zenoh", "inprocess"], default="zenoh", help="default: zenoh")
    run.add_argument("--clock", choices=["lockstep", "realtime"], default="lockstep", help="default: lockstep")
    run.add_argument(
        "--speed", type=_positive, default=None, help="realtime clock only: simulated s per wall s (default: 1)"
    )
    run.add_argument("--seed", type=_seed, default=None, help="random seed (default: the scenario's)")
    run.add_argument("--out", type=Path, default=None, help="MCAP file to write (default: runs/<name>.mcap)")
    run.add_argument("--metrics", type=Path, default=None, help="also write the summary as JSON here")
    run.add_argument("--listen", default=None, help="Zenoh endpoint for the supervisor's router")
    run.add_argument("--connect", default=None, help="join this Zenoh router instead of running one")
    run.add_argument("--remote", type=_ids, default=(), help="vehicle ids started by hand elsewhere (not spawned)")
    run.add_argument(
        "--start-timeout", type=_positive, default=None, metavar="S",
        help=f"zenoh engine: s to wait for every process to come alive (default: {START_TIMEOUT:g})",
    )  # fmt: skip
    run.add_argument("--quiet", action="store_true", help="no progress line")

    vehicle = sub.add_parser("vehicle", help="run one vehicle process (the supervisor starts these)")
    vehicle.add_argument("scenario", type=Path)
    vehicle.add_argument("--id", type=int, required=True, help="vehicle id in the scenario")
    vehicle.add_argument("--connect", required=True, help="Zenoh endpoint of the run's router")
    comms = sub.add_parser("comms", help="run the acoustic-link broker (the supervisor starts it)")
    comms.add_argument("scenario", type=Path)
    comms.add_argument("--seed", type=_seed, default=None)
    comms.add_argument("--connect", required=True, help="Zenoh endpoint of the run's router")
    for command in (run, vehicle, comms):
        command.add_argument(
            "--set", action="append", default=[], metavar="KEY=VALUE", help="override a scenario value (repeatable)"
        )
        command.add_argument(
            "--fault", action="append", default=[], metavar="SPEC",
            help="add a fault, e.g. kind=link_down,sender=1,receiver=2,start=100,end=130 (repeatable)",
        )  # fmt: skip
    vehicle.add_argument("--resume", type=Path, default=None, help="a recorded state message to restart from")
    vehicle.add_argument("--start-step", type=int, default=0, help="the sync step to resume at")
    vehicle.add_argument("--resume-seq", type=int, default=0, help="the last transmission's sequence number")
    vehicle.add_argument(
        "--gamma0", type=float, default=None, help="the initial gamma, when the supervisor resolved 'closest' for it"
    )
    comms.add_argument("--start-step", type=int, default=0, help="the sync step to resume at (after a restart)")
    report = sub.add_parser("report", help="figures and metrics (metrics.json) of a recorded run")
    report.add_argument("log", type=Path, help="MCAP file written by cpf run")
    report.add_argument("--out", type=Path, default=None, help="directory for the figures (default: beside the log)")
    sweep = sub.add_parser("sweep", help="Monte-Carlo over parameter values and seeds (resumable)")
    sweep.add_argument("scenario", type=Path)
    sweep.add_argument(
        "--param", action="append", required=True, metavar="KEY=VALUES",
        help="KEY=v1,v2,... or KEY=start:stop:step, e.g. comms.loss=0:0.8:0.1 (repeatable: a grid)",
    )  # fmt: skip
    sweep.add_argument("--seeds", type=int, default=10, help="runs per parameter combination, seeds 0..N-1")
    sweep.add_argument("--jobs", type=int, default=2, help="runs at once, one process each")
    sweep.add_argument("--engine", choices=["inprocess", "zenoh"], default="inprocess", help="identical results")
    sweep.add_argument("--out", type=Path, required=True, help="directory: runs/, results.csv, plots")
    resim = sub.add_parser("resim", help="re-run the vehicles against the receptions recorded in a log")
    resim.add_argument("log", type=Path, help="MCAP file written by cpf run")
    resim.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=resim_settings.help_text())
    resim.add_argument("--out", type=Path, default=None, help="MCAP file to write (default: <log>.resim.mcap)")
    info = sub.add_parser("info", help="what a recorded run is: scenario, engine, duration, faults, topics")
    info.add_argument("log", type=Path, help="MCAP file written by cpf run (one cut short too)")
    again = sub.add_parser("replay", help="publish a recorded run on Zenoh again, with its original timing")
    again.add_argument("log", type=Path, help="MCAP file written by cpf run")
    again.add_argument("--speed", type=float, default=1.0, help="simulated s per wall s (0: as fast as possible)")
    again.add_argument("--start", type=float, default=None, help="from this simulation time in s (inclusive)")
    again.add_argument("--end", type=float, default=None, help="up to this simulation time in s (inclusive)")
    again.add_argument("--loop", action="store_true", help="replay the window again and again until Ctrl-C")
    where = again.add_mutually_exclusive_group()
    where.add_argument("--listen", default=None, help="endpoint of the replayer's router (default: a free local port)")
    where.add_argument("--connect", default=None, help="join this Zenoh router as a client instead of running one")
    again.add_argument("--delay", type=float, default=None, metavar="S", help="start S s after opening, not on Enter")
    again.add_argument("--quiet", action="store_true", help="no progress line")
    repair = sub.add_parser("recover", help="rebuild the summary and index of a log whose writer was killed")
    repair.add_argument("log", type=Path, help="MCAP file, possibly cut short (no footer, partial last chunk)")
    repair.add_argument("--out", type=Path, default=None, help="MCAP file to write (default: <log>.recovered.mcap)")
    _add_learning_commands(sub)
    for command in sub.choices.values():
        command.formatter_class = _Help
    return parser


def _add_learning_commands(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """schema, validate, presets: the scenario format without reading the source."""
    schema = sub.add_parser("schema", help="the JSON Schema of a scenario file, for editors (or the reference)")
    schema.add_argument("--markdown", action="store_true", help="the scenario reference (docs/scenario-reference.md)")
    check = sub.add_parser("validate", help="check a scenario (every error at once) and say what it would run")
    check.add_argument("scenario", type=Path, help="scenario file (TOML)")
    check.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a value (repeatable)")
    check.add_argument("--fault", action="append", default=[], metavar="SPEC", help="add a fault (repeatable)")
    sub.add_parser("presets", help="the vehicle and modem presets a scenario can name, with their key numbers")


def _option_errors(args: argparse.Namespace, scenario: Scenario) -> list[str]:
    """Option combinations that cannot do what they say, '<option>: <problem>, got <value>' each. Checked before
    anything starts, for both engines alike."""
    from supervisor.config.scenario_schema import VehicleKillFault

    errors = [
        f"--remote: no vehicle {vid} in [[vehicles]] {scenario.vehicle_ids}, got {vid}"
        for vid in args.remote
        if vid not in scenario.vehicle_ids
    ]
    if args.engine == "inprocess":
        given = {"--remote": args.remote or None, "--listen": args.listen, "--connect": args.connect}
        given["--start-timeout"] = args.start_timeout
        errors += [
            f"{option}: only the zenoh engine has processes to place (--engine inprocess runs one), got {value}"
            for option, value in given.items()
            if value is not None
        ]
    if args.speed is not None and args.clock != "realtime":
        errors.append(f"--speed: only the realtime clock is paced (add --clock realtime), got {args.speed:g}")
    killed = {f.vehicle: index for index, f in enumerate(scenario.faults) if isinstance(f, VehicleKillFault)}
    errors += [
        f"--remote: faults[{killed[vid]}] kills vehicle {vid}, which the supervisor cannot do to a process it did "
        f"not start, got {vid}"
        for vid in args.remote
        if vid in killed
    ]
    return errors


def _run(args: argparse.Namespace) -> int:
    from supervisor.analysis.comms_summary import comms_summary, format_comms
    from supervisor.analysis.metrics import finite
    from supervisor.analysis.summary import format_summary, summarize
    from supervisor.config.derived import intervals, tube_radius
    from supervisor.config.scenario import load_scenario
    from supervisor.config.scenario_checks import scenario_warnings
    from supervisor.engine.cosim import BusOptions, run_zenoh
    from supervisor.engine.inprocess import run_inprocess
    from supervisor.engine.progress import Progress
    from supervisor.engine.realtime_timing import format_timing

    scenario = load_scenario(args.scenario, args.set, args.fault)
    errors = [f"{args.scenario}: {line}" for line in _option_errors(args, scenario)]
    if errors:
        raise ScenarioError("\n".join(errors), errors)
    for warning in scenario_warnings(scenario):
        log.warning("%s: %s", args.scenario, warning)
    seed = scenario.scenario.seed if args.seed is None else args.seed
    out = args.out or Path("runs") / f"{scenario.scenario.name}.mcap"
    text = args.scenario.read_text(encoding="utf-8")
    progress = Progress(scenario.scenario.duration, enabled=not args.quiet)
    speed = 1.0 if args.speed is None else args.speed
    if args.engine == "inprocess":
        result = run_inprocess(scenario, str(args.scenario), text, out, seed, progress)
    else:
        timeout = START_TIMEOUT if args.start_timeout is None else args.start_timeout
        bus = BusOptions(args.listen, args.connect, args.remote, tuple(args.set), tuple(args.fault), timeout)
        logging.getLogger("cpf.engine").setLevel(logging.INFO)  # "waiting for ...": --quiet or not
        result = run_zenoh(scenario, args.scenario, text, out, seed, args.clock, speed, bus, progress)
    faults = intervals(scenario)
    rep = scenario.report
    tube = tube_radius(scenario)
    summary = summarize(
        result.series, scenario.scenario.duration, faults, rep.transient, tube, rep.coordination_tolerance
    )
    factor = scenario.scenario.duration / max(result.stepping_time, 1e-9)
    print(
        f"{scenario.scenario.name}: {len(scenario.vehicles)} vehicles, {args.engine} engine, "
        f"{scenario.scenario.duration:g} s simulated in {result.wall_time:.2f} s "
        f"(stepping {result.stepping_time:.2f} s, {factor:.0f}x real time), {result.messages} messages -> {out}"
    )
    comms = comms_summary(result.link_stats, result.stats_history, result.estimate_ages)
    print(format_summary(summary))
    print(format_comms(comms))
    if result.realtime is not None:
        print(format_timing(result.realtime))
    if args.metrics:
        args.metrics.parent.mkdir(parents=True, exist_ok=True)
        metrics = {"coordination": summary.as_dict(), "comms": comms.as_dict(), "links": result.link_counts}
        if result.realtime is not None:
            metrics["realtime"] = result.realtime
        args.metrics.write_text(json.dumps(finite(metrics), indent=2, allow_nan=False))
    return 0


def _vehicle(args: argparse.Namespace) -> int:
    from supervisor.config.fleet import initial_state, radio, restarted_node, vehicle_config
    from supervisor.config.scenario import load_scenario
    from supervisor.config.scenario_digest import hello
    from vehicles.node import run_vehicle
    from vehicles.runtime import NodeState

    scenario = load_scenario(args.scenario, args.set, args.fault)
    if args.id not in scenario.vehicle_ids:
        raise ScenarioError(f"{args.scenario}: --id: no vehicle {args.id} in [[vehicles]] {scenario.vehicle_ids}")
    cfg = vehicle_config(scenario, args.id)
    if args.resume is not None:
        initial = restarted_node(cfg, json.loads(args.resume.read_text()), args.resume_seq)
    else:
        initial = NodeState(initial_state(_starting_at(scenario, args.id, args.gamma0), cfg))
    neighbours, dt = scenario.neighbours(args.id), scenario.scenario.step
    return run_vehicle(
        cfg, initial, radio(scenario, args.id), neighbours, dt, [args.connect], args.start_step,
        hello(f"vehicle {args.id}", scenario),
    )  # fmt: skip


def _starting_at(scenario: Scenario, vid: int, gamma0: float | None) -> Scenario:
    """The scenario with vehicle vid's gamma0 set (the supervisor resolved "closest" for it: no search here); the
    scenario itself, and so its digest, stays the supervisor's."""
    if gamma0 is None:
        return scenario
    vehicles = tuple(v.model_copy(update={"gamma0": gamma0}) if v.id == vid else v for v in scenario.vehicles)
    return scenario.model_copy(update={"vehicles": vehicles})


def _comms(args: argparse.Namespace) -> int:
    from comms.broker import run_broker
    from supervisor.config.fleet import broker_core
    from supervisor.config.scenario import load_scenario
    from supervisor.config.scenario_digest import hello

    scenario = load_scenario(args.scenario, args.set, args.fault)
    seed = scenario.scenario.seed if args.seed is None else args.seed
    dt, ids = scenario.scenario.step, scenario.vehicle_ids
    greeting = hello("comms broker", scenario, seed)
    return run_broker(broker_core(scenario, seed), ids, dt, [args.connect], args.start_step, greeting)


def _report(args: argparse.Namespace) -> int:
    from supervisor.analysis.report import write_report

    for path in write_report(args.log, args.out or args.log.parent):
        print(path)
    return 0


def _info(args: argparse.Namespace) -> int:
    from supervisor.tools.info import overview

    text, problem = overview(args.log)
    print(text)
    if problem is not None:  # described as far as it goes, and still an error: scripts must not take it as whole
        raise problem
    return 0


def _sweep(args: argparse.Namespace) -> int:
    from supervisor.tools.sweep import parse_param, sweep
    from supervisor.tools.sweep_plot import plot_sweep

    if args.seeds < 1 or args.jobs < 1:
        raise ScenarioError(f"--seeds and --jobs must be >= 1, got {args.seeds} and {args.jobs}")
    params = [parse_param(text) for text in args.param]
    rows = sweep(args.scenario, params, args.seeds, args.jobs, args.out, args.engine)
    print(f"{len(rows)} runs -> {args.out / 'results.csv'}")
    for path in plot_sweep(rows, params, args.out):
        print(path)
    return 0


def _resim(args: argparse.Namespace) -> int:
    from supervisor.analysis.summary import format_summary, summarize
    from supervisor.config.derived import intervals, tube_radius
    from supervisor.engine.resim import resimulate

    out = args.out or args.log.with_name(f"{args.log.stem}.resim.mcap")
    sc, original, new = resimulate(args.log, args.set, out)
    rep, duration = sc.report, sc.scenario.duration
    tube = tube_radius(sc)
    for title, series in (("as run", original), (f"re-simulated with {' '.join(args.set) or 'no change'}", new)):
        print(f"{title}:")
        print(
            format_summary(summarize(series, duration, intervals(sc), rep.transient, tube, rep.coordination_tolerance))
        )
    print(f"-> {out}")
    return 0


def _replay(args: argparse.Namespace) -> int:
    from supervisor.tools.replay import ProgressLine, replay, wait_to_start

    progress = ProgressLine()
    try:
        report = replay(
            args.log, args.speed, args.start, args.end, args.loop, args.connect, args.listen,
            wait_to_start(args.delay), None if args.quiet else progress,
        )  # fmt: skip
    finally:
        progress.close()
    print(report.describe())
    return EXIT_INTERRUPTED if report.interrupted and not args.loop else 0


def _recover(args: argparse.Namespace) -> int:
    from supervisor.record.recover import RecoveryError, recover

    if not args.log.is_file():
        raise ScenarioError(f"{args.log}: no such log file")
    out = args.out or args.log.with_name(f"{args.log.stem}.recovered.mcap")
    try:
        report = recover(args.log, out)
    except (RecoveryError, OSError) as exc:
        raise ScenarioError(str(exc)) from exc
    print(f"{args.log} -> {out}: {report.describe()}")
    return 0


def _schema(args: argparse.Namespace) -> int:
    from supervisor.config.reference import markdown, schema_text

    print(markdown() if args.markdown else schema_text(), end="")
    return 0


def _validate(args: argparse.Namespace) -> int:
    from supervisor.config.explain import what_would_run
    from supervisor.config.scenario import load_scenario

    scenario = load_scenario(args.scenario, args.set, args.fault)  # ScenarioError: every error, exit 2
    print(textwrap.fill(f"{args.scenario}: valid. {what_would_run(scenario)}", width=100, break_on_hyphens=False))
    return 0


def _presets(args: argparse.Namespace) -> int:
    from supervisor.config.presets_table import presets_text

    print(presets_text())
    return 0


def _interrupt(signum: int, frame: FrameType | None) -> None:
    """SIGINT and SIGTERM: stop as Ctrl-C does (children stopped, log closed), and keep the request (a run checks it
    every step, should the KeyboardInterrupt be swallowed on its way)."""
    from supervisor.engine.progress import request_stop

    request_stop()
    raise KeyboardInterrupt


COMMANDS = {
    "run": _run,
    "vehicle": _vehicle,
    "comms": _comms,
    "report": _report,
    "info": _info,
    "recover": _recover,
    "sweep": _sweep,
    "resim": _resim,
    "replay": _replay,
    "schema": _schema,
    "validate": _validate,
    "presets": _presets,
}


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format=f"cpf {args.command}: %(message)s")
    signal.signal(signal.SIGTERM, _interrupt)
    signal.signal(signal.SIGINT, _interrupt)
    try:
        return COMMANDS[args.command](args)
    except BrokenPipeError:  # output piped into e.g. head, which stopped reading: not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_RUNTIME
    except ScenarioError as exc:
        for line in exc.errors:  # every error found, one line each
            print(f"cpf: error: {line}", file=sys.stderr)
        return EXIT_INPUT
    except (CpfError, ConnectionError) as exc:
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

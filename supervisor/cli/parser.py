"""The `cpf` argument parser: every command and option, with its help and default."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn, TypeAlias

from comms.records.ids import MAX_VEHICLE_ID
from supervisor.cli import arg_types
from supervisor.engine import resim_settings  # light: the table only, for the help text
from supervisor.errors import ScenarioError

START_TIMEOUT = 60.0  # s: cpf run's default --start-timeout
LIVE_PORT = 8765  # --live without a port: Foxglove's default for a WebSocket connection (record.live.DEFAULT_PORT)
Commands: TypeAlias = "argparse._SubParsersAction[argparse.ArgumentParser]"  # a string: not subscriptable at run time


class _Help(argparse.ArgumentDefaultsHelpFormatter):
    """--help shows every option's default, unless its help already says it or there is none worth showing."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        # a flag's own default says nothing (store_false's True read as "the thing is off by default")
        flag = isinstance(action, argparse._StoreTrueAction | argparse._StoreFalseAction)
        trivial = flag or action.default is None or action.default is False or action.default in ([], ())
        if not action.option_strings or trivial or action.default is argparse.SUPPRESS or "default" in text:
            return action.help
        return f"{text} (default: %(default)s)"


class _Refusing(argparse.ArgumentParser):
    """A parser that raises ScenarioError with argparse's one-line message instead of printing the usage and exiting:
    for the Python API (cpf.run), which must not end its caller's interpreter."""

    def error(self, message: str) -> NoReturn:
        raise ScenarioError(message)


def arguments(argv: Sequence[str]) -> argparse.Namespace:
    """`cpf ARGV...` parsed as the command line parses it (the same options, checks and defaults); ScenarioError
    with argparse's message (what `cpf` prints after 'cpf COMMAND: error: ') for a bad one."""
    return _parser(_Refusing).parse_args(argv)


def _parser(kind: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> argparse.ArgumentParser:
    parser = kind(
        prog="cpf", description="Coordinated path-following co-simulator for AUV fleets.", formatter_class=_Help
    )
    sub = parser.add_subparsers(dest="command", required=True)
    _add_run(sub)
    _add_processes(sub)
    _add_log_commands(sub)
    _add_learning_commands(sub)
    for command in sub.choices.values():
        command.formatter_class = _Help
    return parser


def _add_run(sub: Commands) -> None:
    run = sub.add_parser("run", help="simulate a scenario and record it to MCAP")
    run.add_argument("scenario", type=Path, help="scenario file (TOML)")
    run.add_argument("--engine", choices=["zenoh", "inprocess"], default="zenoh", help="default: zenoh")
    run.add_argument("--clock", choices=["lockstep", "realtime"], default="lockstep", help="default: lockstep")
    run.add_argument(
        "--speed", type=arg_types.speed, default=None, help="realtime clock only: simulated s per wall s (default: 1)"
    )
    run.add_argument(
        "--max-window", type=arg_types.whole(1, 2**63 - 1), default=None, metavar="STEPS",
        help="zenoh engine, lockstep: at most this many steps per time window without the bus (1: a bus round trip "
        "per step, as before windows; default: 100, or fewer while a vehicle may transmit or something changes)",
    )  # fmt: skip
    _add_run_processes(run)
    run.add_argument("--seed", type=arg_types.seed, default=None, help="random seed (default: the scenario's)")
    run.add_argument("--out", type=Path, default=None, help="MCAP file to write (default: runs/<name>.mcap)")
    run.add_argument("--metrics", type=Path, default=None, help="also write the summary as JSON here")
    run.add_argument(
        "--no-foxglove", dest="foxglove", action="store_false",
        help="leave the Foxglove channels (3-D scene, frames, trails) out of the log: ~10-15 %% of an in-process run",
    )  # fmt: skip
    run.add_argument("--listen", default=None, help="Zenoh endpoint for the supervisor's router")
    run.add_argument("--connect", default=None, help="join this Zenoh router instead of running one")
    run.add_argument(
        "--remote", type=arg_types.ids, default=(), help="vehicle ids started by hand elsewhere (not spawned)"
    )
    run.add_argument(
        "--credentials-dir", type=Path, default=None, metavar="DIR",
        help="write the --remote vehicles' credential files here (vehicle-N.json), for cpf vehicle --credentials",
    )  # fmt: skip
    _add_zenoh_config(run)
    _add_live(run, "watch the run in Foxglove as it runs")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    _add_scenario_changes(run)


def _add_run_processes(run: argparse.ArgumentParser) -> None:
    """The zenoh engine's processes: vehicles per process, how they start, how long they may take."""
    run.add_argument(
        "--vehicles-per-process", type=arg_types.per_process, default=None, metavar="M",
        help="zenoh engine: vehicles served by each vehicle process (1: one process per vehicle; default: 1 while "
        "the fleet is at most twice the cores, else one host per core)",
    )  # fmt: skip
    run.add_argument(
        "--start", choices=["fork", "spawn"], default=None,
        help="zenoh engine: processes forked from one that imported what they need (Linux; the default there), or "
        "spawned, each a fresh interpreter",
    )  # fmt: skip
    run.add_argument(
        "--start-timeout", type=arg_types.positive, default=None, metavar="S",
        help=f"zenoh engine: s to wait for every process to come alive (default: {START_TIMEOUT:g})",
    )  # fmt: skip


def _add_scenario_changes(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="override a scenario value (repeatable)"
    )
    command.add_argument(
        "--fault", action="append", default=[], metavar="SPEC",
        help="add a fault, e.g. kind=link_down,sender=1,receiver=2,start=100,end=130 (repeatable)",
    )  # fmt: skip


def _add_zenoh_config(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--zenoh-config", type=Path, default=None, metavar="FILE",
        help="a Zenoh JSON5 config for everything else a site needs; cpf's own settings (mode, endpoints, "
        "scouting, credentials, TLS, access control) go over it",
    )  # fmt: skip


def _add_credentials(command: argparse.ArgumentParser) -> None:
    command.add_argument(
        "--credentials", type=Path, default=None, metavar="FILE",
        help="this process's credential file, as cpf run --credentials-dir wrote it (default: the one the "
        "supervisor hands the processes it starts)",
    )  # fmt: skip
    _add_zenoh_config(command)


def _add_processes(sub: Commands) -> None:
    """vehicle, comms: the processes of a Zenoh run (the supervisor starts them)."""
    vehicle = sub.add_parser(
        "vehicle", help="run a vehicle process, or a host of several (the supervisor starts these)"
    )
    vehicle.add_argument("scenario", type=Path)
    vehicle.add_argument(
        "--id", type=arg_types.whole(1, MAX_VEHICLE_ID), action="append", required=True,
        help="vehicle id in the scenario (repeatable: one process serves them all, each on its own Zenoh session)",
    )  # fmt: skip
    vehicle.add_argument("--connect", required=True, help="Zenoh endpoint of the run's router")
    vehicle.add_argument(
        "--credentials", type=Path, action="append", default=[], metavar="FILE",
        help="a vehicle's credential file, as cpf run --credentials-dir wrote it (repeatable: one per --id; default: "
        "those the supervisor hands the processes it starts)",
    )  # fmt: skip
    _add_zenoh_config(vehicle)
    _add_scenario_changes(vehicle)
    vehicle.add_argument("--seed", type=arg_types.seed, default=None, help="the run's seed (default: the scenario's)")
    vehicle.add_argument("--resume", type=Path, default=None, help="a recorded state message to restart from")
    vehicle.add_argument("--start-step", type=arg_types.step_number, default=0, help="the sync step to resume at")
    vehicle.add_argument(
        "--resume-seq", type=arg_types.step_number, default=0, help="the last transmission's sequence number"
    )
    vehicle.add_argument(
        "--gamma0", type=arg_types.gamma0, action="append", default=[], metavar="[ID=]GAMMA",
        help="the initial gamma of vehicle ID (of the one --id without ID=), when the supervisor resolved 'closest'",
    )  # fmt: skip
    _add_plan(vehicle, "each --id", "--set, --fault, --gamma0, --resume and --start-step")
    _add_broker(sub)


def _add_broker(sub: Commands) -> None:
    comms = sub.add_parser("comms", help="run the acoustic-link broker (the supervisor starts it)")
    comms.add_argument("scenario", type=Path)
    comms.add_argument("--seed", type=arg_types.seed, default=None)
    comms.add_argument("--connect", required=True, help="Zenoh endpoint of the run's router")
    _add_credentials(comms)
    _add_scenario_changes(comms)
    comms.add_argument(
        "--start-step", type=arg_types.step_number, default=0, help="the sync step to resume at (after a restart)"
    )
    _add_plan(comms, "the channel", "--seed, --set and --fault")


def _add_plan(command: argparse.ArgumentParser, served: str, unread: str) -> None:
    """--plan: the private file the supervisor hands a process it starts (comms.bus.handover)."""
    command.add_argument(
        "--plan", type=Path, default=None, metavar="FILE",
        help=f"what to serve {served} with, as the supervisor hands the processes it starts (a private file of its "
        f"run): the scenario file, {unread} are then not read",
    )  # fmt: skip


def _add_live(command: argparse.ArgumentParser, what: str) -> None:
    command.add_argument(
        "--live", type=arg_types.whole(0, 65535), nargs="?", const=LIVE_PORT, default=None, metavar="PORT",
        help=f"{what}: serve Foxglove's WebSocket protocol on 127.0.0.1:PORT (default {LIVE_PORT}; 0: a free port, "
        "printed); in Foxglove: Open connection -> Foxglove WebSocket",
    )  # fmt: skip


def _add_log_commands(sub: Commands) -> None:
    """report, sweep, resim, info: what to do with runs and their logs."""
    report = sub.add_parser("report", help="figures and metrics (metrics.json) of a recorded run")
    report.add_argument("log", type=Path, help="MCAP file written by cpf run")
    report.add_argument("--out", type=Path, default=None, help="directory for the figures (default: beside the log)")
    sweep = sub.add_parser("sweep", help="Monte-Carlo over parameter values and seeds (resumable)")
    sweep.add_argument("scenario", type=Path)
    sweep.add_argument(
        "--param", action="append", required=True, metavar="KEY=VALUES",
        help="KEY=v1,v2,... or KEY=start:stop:step, e.g. comms.loss=0:0.8:0.1 (repeatable: a grid)",
    )  # fmt: skip
    sweep.add_argument(
        "--seeds", type=arg_types.whole(1, 10**6), default=10, help="runs per parameter combination, seeds 0..N-1"
    )
    sweep.add_argument(
        "--jobs",
        type=arg_types.whole(1, 256),
        default=None,
        help="runs at once, one local process each (default: one per core this process may use)",
    )
    sweep.add_argument(
        "--cluster", default=None, metavar="ADDRESS",
        help="send the runs to this Dask scheduler (tcp://host:8786) instead; its workers need cpf-cosim installed",
    )  # fmt: skip
    sweep.add_argument(
        "--cluster-timeout", type=arg_types.within(0.1, 1e6), default=30.0, metavar="S",
        help="s to wait for the scheduler to answer, and for a worker while the cluster has none (default 30)",
    )  # fmt: skip
    sweep.add_argument("--engine", choices=["inprocess", "zenoh"], default="inprocess", help="identical results")
    sweep.add_argument("--out", type=Path, required=True, help="directory: runs/, results.csv, plots")
    sweep.add_argument(
        "--logs", action="store_true",
        help="keep each run's log as runs/<id>.mcap (for cpf report, replay, resim); without, a run records only its "
        "row",
    )  # fmt: skip
    _add_resim(sub)
    info = sub.add_parser("info", help="what a recorded run is: scenario, engine, duration, faults, topics")
    info.add_argument("log", type=Path, help="MCAP file written by cpf run (one cut short too)")
    _add_replay_and_recover(sub)


def _add_resim(sub: Commands) -> None:
    resim = sub.add_parser(
        "resim",
        help="re-run the vehicles against the receptions recorded in a log",
        description="Re-run every vehicle's closed loop against the receptions recorded in a log. By default open "
        "loop across the fleet: each vehicle hears exactly what it heard in the run, its neighbours' gammas as they "
        "were recorded, whatever the re-simulated neighbours now do. --closed-loop keeps the channel's decisions "
        "(the same losses, collisions and delays) and carries the re-simulated senders' gammas.",
    )
    resim.add_argument("log", type=Path, help="MCAP file written by cpf run")
    resim.add_argument(
        "--closed-loop",
        action="store_true",
        help="the recorded receptions carry what the re-simulated senders sent at that time (a reception whose "
        "sender no longer transmits then is dropped and counted); without it, the recorded gammas",
    )
    resim.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=resim_settings.help_text())
    resim.add_argument("--out", type=Path, default=None, help="MCAP file to write (default: <log>.resim.mcap)")


def _add_replay_and_recover(sub: Commands) -> None:
    again = sub.add_parser(
        "replay",
        help="publish a recorded run on Zenoh again, with its original timing",
        description="Publish a recorded run on Zenoh again. While it plays, queries on cpf/replay/control steer it "
        "(pause, resume, seek t=T, seek dt=S, speed x=X, state) and so, in a terminal, do the keys: space "
        "pause/resume, + faster, - slower, left/right seek 10 s, q quit.",
    )
    again.add_argument("log", type=Path, help="MCAP file written by cpf run")
    again.add_argument(
        "--speed", type=arg_types.pace, default=1.0, help="simulated s per wall s (0: as fast as possible)"
    )
    again.add_argument(
        "--start", type=arg_types.number, default=None, help="from this simulation time in s (inclusive)"
    )
    again.add_argument("--end", type=arg_types.number, default=None, help="up to this simulation time in s (inclusive)")
    again.add_argument("--loop", action="store_true", help="replay the window again and again until Ctrl-C")
    where = again.add_mutually_exclusive_group()
    where.add_argument("--listen", default=None, help="endpoint of the replayer's router (default: a free local port)")
    where.add_argument("--connect", default=None, help="join this Zenoh router as a client instead of running one")
    again.add_argument(
        "--delay", type=arg_types.pace, default=None, metavar="S", help="start S s after opening, not on Enter"
    )
    _add_live(again, "watch the replay in Foxglove (the log's scene, or one built from its records)")
    again.add_argument("--quiet", action="store_true", help="no progress line")
    _add_zenoh_config(again)
    _add_export(sub)
    repair = sub.add_parser("recover", help="rebuild the summary and index of a log whose writer was killed")
    repair.add_argument("log", type=Path, help="MCAP file, possibly cut short (no footer, partial last chunk)")
    repair.add_argument("--out", type=Path, default=None, help="MCAP file to write (default: <log>.recovered.mcap)")


def _add_export(sub: Commands) -> None:
    export = sub.add_parser(
        "export", help="a recorded run as tables: states, transmissions, receptions, ... (docs/api.md)"
    )
    export.add_argument("log", type=Path, help="MCAP file written by cpf run")
    export.add_argument("--format", choices=["csv", "parquet"], default="csv", help="one file per table")
    export.add_argument("--out", type=Path, required=True, help="directory for the tables (made if missing)")


def _add_learning_commands(sub: Commands) -> None:
    """schema, validate, presets, stability: the scenario format, and what it would do, without running it."""
    schema = sub.add_parser("schema", help="the JSON Schema of a scenario file, for editors (or the reference)")
    schema.add_argument("--markdown", action="store_true", help="the scenario reference (docs/scenario-reference.md)")
    check = sub.add_parser("validate", help="check a scenario (every error at once) and say what it would run")
    check.add_argument("scenario", type=Path, help="scenario file (TOML)")
    check.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a value (repeatable)")
    check.add_argument("--fault", action="append", default=[], metavar="SPEC", help="add a fault (repeatable)")
    presets = sub.add_parser(
        "presets", help="the vehicle and modem presets a scenario can name, with their key numbers"
    )
    presets.add_argument("name", nargs="?", help="one preset (vehicle or modem): every parameter it sets, with units")
    sub.add_parser(
        "plugins",
        help="the coordination laws, predictors, transmission policies, controllers and vehicle models installed "
        "(built-ins included)",
    )
    stable = sub.add_parser(
        "stability", help="predict whether coordination converges, and the period, delay and loss it tolerates"
    )
    stable.add_argument("scenario", type=Path, help="scenario file (TOML)")
    stable.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a value (repeatable)")
    _add_per(sub)


def _add_per(sub: Commands) -> None:
    per = sub.add_parser("per", help="plot packet error against range for the modem presets (link budget, fading)")
    per.add_argument(
        "--modem", action="append", default=[], metavar="NAME",
        help="modem preset (repeatable; default: every preset with a bitrate)",
    )  # fmt: skip
    for flag, kind, default, metavar, text in (
        ("--source-level", arg_types.within(0.0, 300.0), 185.0, "DB", "source level, dB re 1 uPa at 1 m"),
        ("--bytes", arg_types.whole(1, 65536), 15, "B", "packet size before padding to the modem's frames"),
        (
            "--shadowing",
            arg_types.within(0.0, 30.0),
            4.0,
            "DB",
            "log-normal shadowing, standard deviation in dB (0: none)",
        ),
        ("--rician-k", _k_factor, 1.0, "K", "fast fading: Rician K factor, 0 for Rayleigh, 'none' for no fast fading"),
        ("--spreading", arg_types.within(1.0, 2.0), 1.5, "K", "spreading exponent"),
        ("--draws", arg_types.whole(10, 1_000_000), 2000, "N", "packets drawn per marked range (the dots)"),
    ):
        per.add_argument(flag, type=kind, default=default, metavar=metavar, help=text)
    per.add_argument("--out", type=Path, default=Path("per.png"), help="PNG file to write")


def _k_factor(text: str) -> float | None:
    return None if text.strip().lower() == "none" else arg_types.within(0.0, 1000.0)(text)

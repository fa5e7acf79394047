"""The `cpf` commands on logs and scenario files: report, info, recover, export, sweep, resim, replay, schema,
validate, presets, per. Each reads its arguments, calls the library, and prints what the user sees."""

from __future__ import annotations

import argparse
import logging
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

from supervisor.errors import EXIT_INTERRUPTED, ScenarioError

if TYPE_CHECKING:
    from supervisor.tools.sweep_params import Param

log = logging.getLogger("cpf")


def report(args: argparse.Namespace) -> int:
    from supervisor.cli.outputs import made_directory
    from supervisor.record.logfile import open_log

    open_log(args.log).close()  # LogError for a missing log or another file, before anything is made
    made_directory("--out", args.out or args.log.parent)
    from supervisor.analysis.aside import aside
    from supervisor.analysis.rundata import read_for_report

    with aside(read_for_report, args.log) as reading:  # the log read in a child while matplotlib loads here
        from supervisor.analysis.comms_summary import format_malformed
        from supervisor.analysis.report import write_report
        from supervisor.record.provenance import drawn_from

        read = reading.result()
        paths = write_report(args.log, args.out or args.log.parent, read)
    if (source := drawn_from(args.log)) is not None:
        print(f"{args.log}: {source}")
    if (dropped := format_malformed(*read[0].drops)) is not None:  # the line cpf run printed: the log has the drops
        print(dropped)
    for path in paths:
        print(path)
    return 0


def info(args: argparse.Namespace) -> int:
    from supervisor.tools.info import overview

    text, problem = overview(args.log)
    print(text)
    if problem is not None:  # described as far as it goes, and still an error: scripts must not take it as whole
        raise problem
    return 0


def export(args: argparse.Namespace) -> int:
    from supervisor.cli.outputs import made_directory
    from supervisor.record.logfile import open_log

    open_log(args.log).close()  # LogError for a missing log or another file, before anything is made
    made_directory("--out", args.out)
    from supervisor.tools.export import export_tables  # pandas: only once the arguments are known good

    for path in export_tables(args.log, args.format, args.out):
        print(path)
    return 0


def sweep(args: argparse.Namespace) -> int:
    from supervisor.cli.terminal import SweepBar
    from supervisor.tools.sweep import Cluster, local_jobs, sweep
    from supervisor.tools.sweep_plot import plot_sweep

    params = sweep_params(args)
    cluster = None if args.cluster is None else Cluster(args.cluster, args.cluster_timeout)
    bar = SweepBar()
    try:
        rows = sweep(args.scenario, params, args.seeds, args.jobs, args.out, args.engine, bar, cluster, args.logs)
    finally:
        bar.close()
    at_once = "on the cluster" if cluster is not None else f"{local_jobs(args.jobs)} at once"
    print(f"{len(rows)} run{'s' if len(rows) != 1 else ''} ({at_once}) -> {args.out / 'results.csv'}")
    for path in plot_sweep(rows, params, args.out):
        print(path)
    return 0


def sweep_params(args: argparse.Namespace) -> list[Param]:
    """`cpf sweep`'s parameters, once its arguments are checked before anything runs (by cpf.sweep too): --jobs not
    with --cluster, each --param, --out a directory that can be made; ScenarioError for the first that is not."""
    from supervisor.cli.outputs import checked_directory
    from supervisor.tools.sweep_params import parse_param

    if args.cluster is not None and args.jobs is not None:  # the workers' threads say how many runs go at once
        raise ScenarioError(f"--jobs: local processes, not for a sweep on a --cluster, got {args.jobs}")
    params = [parse_param(text) for text in args.param]
    checked_directory("--out", args.out)  # made once the sweep starts: an unreachable cluster leaves nothing
    return params


def resim(args: argparse.Namespace) -> int:
    from supervisor.analysis.summary import format_summary, summarize
    from supervisor.cli.outputs import checked_file
    from supervisor.config.derived import intervals, tube_radius
    from supervisor.engine.resim import resimulate
    from supervisor.engine.resim_loop import ClosedLoop

    out = checked_file("--out", args.out or args.log.with_name(f"{args.log.stem}.resim.mcap"), args.log)
    loop = ClosedLoop() if args.closed_loop else None
    sc, original, new, agreement = resimulate(args.log, args.set, out, loop)
    rep, duration = sc.report, sc.scenario.duration
    tube = tube_radius(sc)
    how = "closed loop: the recorded channel, the re-simulated gammas" if loop else "open loop: the recorded gammas"
    for title, series in (
        ("as run", original),
        (f"re-simulated ({how}) with {' '.join(args.set) or 'no change'}", new),
    ):
        print(f"{title}:")
        print(
            format_summary(summarize(series, duration, intervals(sc), rep.transient, tube, rep.coordination_tolerance))
        )
    if loop is not None and loop.unmatched:
        print(f"{loop.unmatched} recorded receptions dropped: their sender did not transmit at that time any more")
    print(agreement.line())
    print(f"-> {out}")
    return 0


def replay(args: argparse.Namespace) -> int:
    from supervisor.cli.live_view import live_view
    from supervisor.cli.replay_keys import keyboard
    from supervisor.cli.terminal import ProgressLine, wait_to_start
    from supervisor.tools.replay import replay

    progress = ProgressLine()
    try:
        with live_view(args.live, "cpf replay", tell_subscriptions=True) as live:
            report = replay(
                args.log, args.speed, args.start, args.end, args.loop, args.connect, args.listen,
                wait_to_start(args.delay), None if args.quiet else progress, keyboard, args.zenoh_config, live,
            )  # fmt: skip
    finally:
        progress.close()
    print(report.describe())
    # Ctrl-C or SIGTERM is 130 as for every command, --loop too (which only a stop or a quit ends: a quit is 0)
    return EXIT_INTERRUPTED if report.interrupted else 0


def recover(args: argparse.Namespace) -> int:
    from supervisor.cli.outputs import checked_file
    from supervisor.errors import RecoveryError
    from supervisor.record.recover import recover

    if not args.log.is_file():
        raise ScenarioError(f"{args.log}: {'not a log file' if args.log.exists() else 'no such log file'}")
    out = checked_file("--out", args.out or args.log.with_name(f"{args.log.stem}.recovered.mcap"), args.log)
    try:
        report = recover(args.log, out)
    except RecoveryError as exc:
        raise ScenarioError(str(exc)) from exc
    except OSError as exc:  # the log unreadable is bad input; --out unwritable now (a full disk) is the run-time's
        if exc.filename is None or Path(exc.filename) != args.log:
            raise
        raise ScenarioError(f"{args.log}: cannot read the log: {exc.strerror or exc}") from None
    print(f"{args.log} -> {out}: {report.describe()}")
    return 0


def schema(args: argparse.Namespace) -> int:
    from supervisor.config.reference import markdown, schema_text

    print(markdown() if args.markdown else schema_text(), end="")
    return 0


def validate(args: argparse.Namespace) -> int:
    from supervisor.config.explain import what_would_run
    from supervisor.config.scenario import load_scenario
    from supervisor.config.scenario_checks import scenario_warnings

    scenario = load_scenario(args.scenario, args.set, args.fault)  # ScenarioError: every error, exit 2
    for warning in scenario_warnings(scenario):  # what cpf run would warn about, said here too
        log.warning("%s: %s", args.scenario, warning)
    print(textwrap.fill(f"{args.scenario}: valid. {what_would_run(scenario)}", width=100, break_on_hyphens=False))
    return 0


def plugins(args: argparse.Namespace) -> int:
    from supervisor.config.extensions import plugins_text

    print(plugins_text())
    return 0


def stability(args: argparse.Namespace) -> int:
    from supervisor.config.links import unmodelled
    from supervisor.config.scenario import load_scenario
    from supervisor.config.stability.scenario import analyse, describe

    scenario = load_scenario(args.scenario, args.set)  # ScenarioError: every error, exit 2
    if (why := unmodelled(scenario)) is not None:  # a loop it cannot linearise: said, not guessed at
        raise ScenarioError(f"{args.scenario}: {why}; cpf stability cannot analyse this loop")
    text = describe(analyse(scenario), scenario)
    print(textwrap.fill(f"{args.scenario}: {text}", width=100, break_on_hyphens=False))
    return 0


def presets(args: argparse.Namespace) -> int:
    from comms.channel.modem import PRESETS as MODEMS
    from supervisor.config.presets_table import preset_text, presets_text
    from vehicles.params import PRESETS

    if args.name is None:
        print(presets_text())
    elif args.name in PRESETS or args.name in MODEMS:
        print(preset_text(args.name))
    else:
        raise ScenarioError(f"cpf presets: no preset {args.name!r}, expected one of {sorted([*PRESETS, *MODEMS])}")
    return 0


def per(args: argparse.Namespace) -> int:
    from supervisor.cli.outputs import checked_file
    from supervisor.tools.per_plot import Channel, modem_names, plot_per

    try:
        names = modem_names(args.modem)
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    channel = Channel(args.source_level, args.bytes, args.shadowing, args.rician_k, args.spreading, args.draws)
    print(plot_per(names, channel, checked_file("--out", args.out)))
    return 0

"""`cpf run`, and `cpf vehicle` / `cpf comms`: the processes a Zenoh run starts."""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from supervisor.cli.live_view import live_view
from supervisor.cli.outputs import output_errors
from supervisor.cli.parser import START_TIMEOUT
from supervisor.cli.run_report import report_run
from supervisor.errors import ScenarioError

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from comms.broker.broker_start import BrokerStart
    from comms.bus.access import Credential
    from comms.bus.bus import Ending, Extras
    from supervisor.config.scenario_schema import Scenario
    from supervisor.engine.inprocess import RunResult
    from supervisor.record.live import LiveView
    from vehicles.start import VehicleStart

log = logging.getLogger("cpf")


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
        given |= {"--start-timeout": args.start_timeout, "--credentials-dir": args.credentials_dir}
        given |= {"--zenoh-config": args.zenoh_config, "--vehicles-per-process": args.vehicles_per_process}
        given |= {"--start": args.start}
        errors += [
            f"{option}: only the zenoh engine has processes to place (--engine inprocess runs one), got {value}"
            for option, value in given.items()
            if value is not None
        ]
    if args.max_window is not None and (args.engine != "zenoh" or args.clock != "lockstep"):
        errors.append(f"--max-window: only the zenoh engine's lockstep clock has time windows, got {args.max_window}")
    if args.speed is not None and args.clock != "realtime":
        errors.append(f"--speed: only the realtime clock is paced (add --clock realtime), got {args.speed:g}")
    killed = {f.vehicle: index for index, f in enumerate(scenario.faults) if isinstance(f, VehicleKillFault)}
    errors += [
        f"--remote: faults[{killed[vid]}] kills vehicle {vid}, which the supervisor cannot do to a process it did "
        f"not start, got {vid}"
        for vid in args.remote
        if vid in killed
    ]
    if args.engine == "zenoh":
        from supervisor.config.extension_checks import unloadable_errors

        errors += [*_bus_errors(args), *unloadable_errors(scenario)]
    return errors


def _bus_errors(args: argparse.Namespace) -> list[str]:
    """Who may reach the run's bus, and how: what --listen, --remote, --credentials-dir and --zenoh-config ask for
    must be safe and possible (supervisor.engine.bus_access)."""
    from comms.bus.bus import site_config
    from supervisor.engine.bus_access import is_loopback, is_tls

    errors, router, given = [], args.connect is None, args.credentials_dir
    if router and args.listen and not is_loopback(args.listen) and not is_tls(args.listen):
        errors.append(
            f"--listen: other hosts can reach this address, so the bus must be encrypted: use tls/ (for example "
            f"tls/0.0.0.0:7447), got {args.listen}"
        )
    if router and args.remote and given is None:
        ids = ",".join(str(v) for v in args.remote)
        errors.append(f"--remote: vehicles started by hand need credentials: add --credentials-dir DIR, got {ids}")
    if given is not None and not (router and args.remote):
        errors.append(
            f"--credentials-dir: only vehicles started by hand (--remote) for this supervisor's router (no --connect) "
            f"need credential files, got {given}"
        )
    if given is not None and given.exists() and not given.is_dir():
        errors.append(f"--credentials-dir: not a directory, got {given}")
    if args.zenoh_config is not None:
        try:
            site_config(args.zenoh_config)
        except ValueError as exc:
            errors.append(f"--zenoh-config: {exc}, got {args.zenoh_config}")
    return errors


def run(args: argparse.Namespace) -> int:
    scenario, result, out = execute(args)
    report_run(args, scenario, result, out)
    return 0


def execute(args: argparse.Namespace) -> tuple[Scenario, RunResult, Path]:
    """`cpf run` but what it prints and --metrics: the scenario checked (ScenarioError), simulated on the engine asked
    for with the progress line on stderr (unless --quiet) and recorded to the log; the scenario, the result and the
    log's path. The command line prints its summary and writes --metrics from these (supervisor.cli.run_report), the
    Python API (cpf.run) writes --metrics alike and reads the log."""
    scenario = _checked_scenario(args)
    out = _log_path(args, scenario)
    with live_view(args.live, "cpf run") as live:
        result = _simulate(args, scenario, out, live)
    return scenario, result, out


def _checked_scenario(args: argparse.Namespace) -> Scenario:
    """The scenario with --set and --fault applied; ScenarioError for it or for options that do not fit it; its
    warnings logged."""
    from supervisor.config.scenario import load_scenario
    from supervisor.config.scenario_checks import scenario_warnings

    scenario = load_scenario(args.scenario, args.set, args.fault)
    outputs = {"--out": _log_path(args, scenario), "--metrics": args.metrics}
    lines = _option_errors(args, scenario) + output_errors(args.scenario, outputs)
    errors = [f"{args.scenario}: {line}" for line in lines]
    if errors:
        raise ScenarioError("\n".join(errors), errors)
    for warning in scenario_warnings(scenario):
        log.warning("%s: %s", args.scenario, warning)
    return scenario


def _log_path(args: argparse.Namespace, scenario: Scenario) -> Path:
    """--out, or runs/<name>.mcap (the name is a name, not a path: the schema holds it to one)."""
    return Path(args.out) if args.out is not None else Path("runs") / f"{scenario.scenario.name}.mcap"


def _simulate(args: argparse.Namespace, scenario: Scenario, out: Path, live: LiveView | None) -> RunResult:
    from supervisor.engine.cosim import BusOptions, run_zenoh
    from supervisor.engine.inprocess import run_inprocess
    from supervisor.engine.progress import Progress

    seed = scenario.scenario.seed if args.seed is None else args.seed
    text = args.scenario.read_text(encoding="utf-8")
    bar = getattr(args, "bar", False)  # set by cpf.run, not an option of the command line
    progress = Progress(scenario.scenario.duration, sys.stderr, enabled=not args.quiet, bar=bar)
    speed = 1.0 if args.speed is None else args.speed
    try:  # the bar closed however the run ends (a Ctrl-C in a notebook left it there)
        if args.engine == "inprocess":
            paced = speed if args.clock == "realtime" else None
            return run_inprocess(scenario, str(args.scenario), text, out, seed, progress, args.foxglove, live, paced)
        timeout = START_TIMEOUT if args.start_timeout is None else args.start_timeout
        changes = (tuple(args.set), tuple(args.fault))
        bus = BusOptions(args.listen, args.connect, args.remote, *changes, timeout, args.credentials_dir,
                         args.zenoh_config)  # fmt: skip
        bus.per_process = args.vehicles_per_process
        bus.fork = args.start != "spawn"
        logging.getLogger("cpf.engine").setLevel(logging.INFO)  # "waiting for ...": --quiet or not
        how = (args.clock, speed, bus, progress, args.max_window)
        return run_zenoh(scenario, args.scenario, text, out, seed, *how, scene=args.foxglove, live=live)
    finally:
        progress.close()


def vehicle(args: argparse.Namespace) -> int:
    """One vehicle process, or a host of several (vehicles.host): each vehicle on its own session, credential and
    keys, as if alone. Started by the supervisor (--plan), it serves what the supervisor handed it; started by hand,
    what it builds from the scenario file."""
    ids: list[int] = list(dict.fromkeys(args.id))
    starts = _planned(args.plan, ids) if args.plan is not None else _from_scenario(args, ids)
    extras = _vehicle_extras(args, ids)
    if len(ids) == 1:
        return _serve_vehicle(args, starts[0], extras[ids[0]])(None)
    from vehicles.host import run_host

    name = "vehicles " + ",".join(map(str, ids))
    return run_host(name, {s.cfg.vehicle_id: _serve_vehicle(args, s, extras[s.cfg.vehicle_id]) for s in starts})


def _planned(plan: Path, ids: list[int]) -> Sequence[VehicleStart]:
    """The starts the supervisor handed over (vehicles.start: no scenario loaded, no pydantic imported); ScenarioError
    for a file that is not one, or not of the vehicles of --id."""
    from vehicles.start import read_starts

    try:
        starts = read_starts(plan)
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None  # '<file>: <problem>'
    planned = [s.cfg.vehicle_id for s in starts]
    if planned != ids:
        raise ScenarioError(f"{plan}: the vehicles of --id {ids} are not those it starts, got {planned}")
    return starts


def _from_scenario(args: argparse.Namespace, ids: list[int]) -> Sequence[VehicleStart]:
    """The starts of a vehicle started by hand, from the scenario file with --set and --fault (and --gamma0,
    --resume); ScenarioError for a bad scenario or options that do not fit it."""
    from supervisor.config.scenario import load_scenario
    from supervisor.config.vehicle_start import vehicle_starts

    scenario = load_scenario(args.scenario, args.set, args.fault)
    unknown = [vid for vid in ids if vid not in scenario.vehicle_ids]
    if unknown:
        raise ScenarioError(f"{args.scenario}: --id: no vehicle {unknown[0]} in [[vehicles]] {scenario.vehicle_ids}")
    if args.resume is not None and len(ids) > 1:
        raise ScenarioError(f"--resume: restarts one vehicle, got --id {', '.join(map(str, ids))}")
    gamma0 = _gamma0_of(args.gamma0, ids)
    resume = (json.loads(args.resume.read_text()), args.resume_seq) if args.resume is not None else None
    seed = scenario.scenario.seed if args.seed is None else args.seed
    return vehicle_starts(scenario, ids, gamma0, resume, args.start_step, seed)


def _serve_vehicle(args: argparse.Namespace, start: VehicleStart, extras: Extras) -> Callable[[Ending | None], int]:
    """What serves one vehicle until it ends."""
    from vehicles.node import run_vehicle

    cfg, initial, dt, connect = start.cfg, start.initial, start.dt, [args.connect]
    return lambda ending: run_vehicle(
        cfg, initial, start.radio, start.neighbours, dt, connect, start.start_step, start.hello, extras, ending
    )


def _gamma0_of(given: list[tuple[int | None, float]], ids: list[int]) -> dict[int, float]:
    """--gamma0 [ID=]GAMMA by vehicle; ScenarioError for one without ID in a host, or of a vehicle not served."""
    out = {}
    for vid, value in given:
        if vid is None and len(ids) > 1:
            raise ScenarioError(f"--gamma0: name the vehicle (ID=GAMMA) when serving several, got {value!r}")
        vid = ids[0] if vid is None else vid
        if vid not in ids:
            raise ScenarioError(f"--gamma0: vehicle {vid} is not one this process serves (--id), got {vid}={value!r}")
        out[vid] = value
    return out


def comms(args: argparse.Namespace) -> int:
    """The broker process. Started by the supervisor (--plan), it serves what the supervisor handed it; started by
    hand, what it builds from the scenario file."""
    from comms.broker.broker import run_broker

    start = _planned_broker(args.plan) if args.plan is not None else _broker_from_scenario(args)
    extras = _process_extras(args, "comms broker")
    return run_broker(start.core, start.vehicles, start.dt, [args.connect], args.start_step, start.hello, extras)


def _planned_broker(plan: Path) -> BrokerStart:
    """The start the supervisor handed over (no scenario loaded, no pydantic imported); ScenarioError for a file
    that is not one."""
    from comms.broker.broker_start import read_broker_start

    try:
        return read_broker_start(plan)
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None  # '<file>: <problem>'


def _broker_from_scenario(args: argparse.Namespace) -> BrokerStart:
    from supervisor.config.broker_start import broker_start
    from supervisor.config.scenario import load_scenario

    scenario = load_scenario(args.scenario, args.set, args.fault)
    return broker_start(scenario, scenario.scenario.seed if args.seed is None else args.seed)


def _vehicle_extras(args: argparse.Namespace, ids: list[int]) -> dict[int, Extras]:
    """Each vehicle's extras: its credential from the --credentials files (or those its supervisor handed it, by
    name), one for every --id or none at all; ScenarioError if one is missing or another process's."""
    from comms.bus.access import ENV, read_credential

    where = ", ".join(str(p) for p in args.credentials) if args.credentials else f"${ENV}"
    handed = [Path(p) for p in os.environ.get(ENV, "").split(os.pathsep) if p]  # a host's: one per vehicle
    try:
        given = [read_credential(p) for p in args.credentials or handed]
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None  # '<file>: <problem>'
    names = {f"vehicle {vid}": vid for vid in ids}
    stranger = next((c.name for c in given if c.name not in names), None)
    if stranger is not None:
        raise ScenarioError(f"{where}: name: these are the credentials of another process, got {stranger}")
    mine = {names[c.name]: c for c in given}
    if mine and len(mine) < len(ids):
        missing = next(vid for vid in ids if vid not in mine)
        raise ScenarioError(f"{where}: name: no credentials of vehicle {missing} among them, got {sorted(names)}")
    return {vid: _extras(args, mine.get(vid)) for vid in ids}


def _process_extras(args: argparse.Namespace, name: str) -> Extras:
    """The broker's credential (--credentials, else the one its supervisor handed it) and the site's Zenoh config;
    ScenarioError for a file that is not one, or another process's credential."""
    from comms.bus.access import ENV, credential_from_env, read_credential

    where = str(args.credentials) if args.credentials is not None else f"${ENV}"
    try:
        credential = read_credential(args.credentials) if args.credentials is not None else credential_from_env()
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None  # '<file>: <problem>'
    if credential is not None and credential.name != name:
        raise ScenarioError(f"{where}: name: these are the credentials of another process, got {credential.name}")
    return _extras(args, credential)


def _extras(args: argparse.Namespace, credential: Credential | None) -> Extras:
    """A session's extras: the credential's settings over the site's Zenoh config (ScenarioError if that is not one)."""
    from comms.bus.access import client_config
    from comms.bus.bus import Extras, site_config

    if args.zenoh_config is not None:
        try:
            site_config(args.zenoh_config)
        except ValueError as exc:
            raise ScenarioError(f"--zenoh-config: {exc}, got {args.zenoh_config}") from None
    entries = client_config(credential) if credential is not None else {}
    return Extras(args.zenoh_config, entries, credentials=credential is not None)

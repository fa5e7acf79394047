"""The multi-process engine: the supervisor's side of a run over Eclipse Zenoh.

The supervisor opens a Zenoh router on a free localhost port (or the given endpoint), starts the broker and one
process per vehicle, waits for their liveliness tokens, then drives the clock: tick k (carrying every fault in force
over the step), wait for every live vehicle's state of step k, tick k+1, ... Lockstep runs as fast as the machine
allows; realtime paces the ticks to the wall clock. Everything on the bus is recorded to MCAP. Scheduled process
faults are carried out here (SIGKILL, restart where the vehicle coasted to from its last recorded state); a process
that disappears is noticed through its liveliness token and, for a vehicle, handled by scenario.on_vehicle_loss. The
router admits only the run's processes, each with credentials made for the run, and lets each do only its part
(supervisor.engine.bus_access).
"""

from __future__ import annotations

import contextlib
import logging
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import zenoh

from comms.bus.access import done_key_pattern
from comms.bus.bus import Inbox, Publishers, answer_flushes, free_port, open_session
from comms.records.messages import (
    ALIVE_PREFIX,
    COMMS_DONE_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    GRAPH_KEY,
    META_KEY,
    ROOT,
    RUN_DONE_KEY,
    STOP_END,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    Message,
)
from comms.records.run import Graph, Stop
from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_schema import Scenario
from supervisor.engine import interrupts
from supervisor.engine.bus_access import run_access
from supervisor.engine.clock import Clock
from supervisor.engine.inprocess import RunResult
from supervisor.engine.intake import Intake
from supervisor.engine.launch import START_TIMEOUT, BusOptions, Launch, local, reachable
from supervisor.engine.progress import Progress
from supervisor.engine.realtime_timing import RealtimeTiming
from supervisor.engine.startup import Hellos, ask_hello
from supervisor.engine.supervisor import Supervisor
from supervisor.processes import ProcessGroup
from supervisor.record.meta import RunMeta
from supervisor.record.recorder import LiveSink, Recorder

__all__ = ["START_TIMEOUT", "BusOptions", "run_zenoh"]
STEP_TIMEOUT = 60.0  # s for one sync step before the run is declared stuck
log = logging.getLogger("cpf.engine")


@interrupts.deferring
def run_zenoh(
    scenario: Scenario,
    scenario_path: Path,
    scenario_toml: str,
    out: Path,
    seed: int,
    clock: str,
    speed: float,
    bus: BusOptions,
    progress: Progress,
    longest: int | None = None,
    scene: bool = True,
    live: LiveSink | None = None,
) -> RunResult:
    """Run the scenario over Zenoh with one process per vehicle and a broker; record everything to out. longest:
    lockstep time windows of at most this many steps (1: one bus round trip per step; None: as long as nothing can
    cross the bus). scene: the log gets the run's Foxglove channels (record.scene); live: sees every record too."""
    _loaded_alike(scenario, scenario_path, bus)
    endpoint = bus.listen or f"tcp/127.0.0.1:{free_port()}"
    timing = RealtimeTiming(scenario.scenario.step) if clock == "realtime" else None
    how = (scenario_path, endpoint, bus, seed)
    meta = RunMeta.of(scenario, str(scenario_path), scenario_toml, seed, "zenoh", clock).to_message()
    with Recorder(out, scene, live) as rec:
        intake, started = Intake(scenario, rec, timing), []  # started: the supervisor, once it is
        try:
            with _supervisor(scenario, how, intake, (clock, speed, longest)) as run:
                started.append(run)
                _open(run, rec, meta, endpoint)
                _drive(run, progress)
                stepping, wall = progress.stepping_time(), progress.done(run.t)
        except BaseException:
            with contextlib.suppress(Exception):  # already failing (the log itself, maybe): the first error stands
                _log_drops(rec, intake, started[0].t if started else 0.0)
            raise
        _log_drops(rec, intake, run.t)
    books, builder, drops = intake.books, intake.builder, intake.bus_drops()
    return RunResult(  # rec.count once the log is closed: the stop message and the vehicles' reports come last
        builder.series(), wall, rec.count, books.counts, books.stats.snapshot(run.t), books.lambda2, builder.ages,
        stepping, timing.as_dict() if timing is not None else None, drops.by_key, rec.scene_count, drops.by_cause,
    )  # fmt: skip


def _loaded_alike(scenario: Scenario, path: Path, bus: BusOptions) -> None:
    """ValueError unless the scenario is what every child process will load: path with the bus's overrides."""
    if load_scenario(path, bus.overrides, bus.faults) != scenario:
        raise ValueError(f"run_zenoh: the scenario is not {path} with bus.overrides and bus.faults")


def _log_drops(rec: Recorder, intake: Intake, t: float) -> None:
    """The supervisor's end-of-run report, once its processes are gone (the bus with them): all it dropped, for
    `cpf report` to read from the log, a run that failed too."""
    rec.write(RUN_DONE_KEY, t, intake.own_done(t).to_message())


def _open(run: Supervisor, rec: Recorder, meta: Message, endpoint: str) -> None:
    """The run's meta in the log from the start (a run that never starts, a process missing or refused, still says
    what it was), its processes started, then the meta and the graph on the bus."""
    rec.limit(run.sc.scenario.duration)  # a message stamped later (forged, broken) is refused
    rec.write(META_KEY, 0.0, meta)
    _start(run, endpoint)
    run.pubs.put(META_KEY, meta)
    run.publish(GRAPH_KEY, 0.0, Graph.of(0.0, run.sc.graph.edges).to_message())


@contextlib.contextmanager
def _supervisor(
    sc: Scenario, how: tuple[Path, str, BusOptions, int], intake: Intake, pacing: tuple[str, float, int | None]
) -> Iterator[Supervisor]:
    """The supervisor on its Zenoh session (how: scenario file, endpoint, bus options, seed), with its process
    group; on the way out (whatever happened) the stop message, the children given time to leave, then the process
    group stops whatever is left."""
    path, endpoint, bus, seed = how
    mode, listen, connect = ("client", [], [bus.connect]) if bus.connect else ("router", [endpoint], [])
    with (
        run_access(sc, bus, endpoint) as access,
        open_session(mode, listen, connect, access.router) as session,
        ProcessGroup(access.env_of, access.fds_of, fork=str(path) if bus.fork else None) as procs,
        tempfile.TemporaryDirectory(prefix="cpf-run-") as private_dir,
    ):
        inbox = _inbox(session)
        flushes = answer_flushes(session)  # the children's last messages are in before they go (comms.bus.bus.flush)
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)
        pubs = Publishers(session)
        hellos = Hellos.of(sc, seed, lambda key: ask_hello(session, key))
        launch = Launch(path, bus.connect or local(endpoint), bus, seed, Path(private_dir))
        clock = Clock(sc, pubs, *pacing)
        run = Supervisor(sc, bus=(inbox, pubs), procs=procs, launch=launch, hellos=hellos, intake=intake, clock=clock)
        reason = STOP_END
        try:
            yield run
        except BaseException as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise
        finally:
            with contextlib.suppress(Exception):  # already failing: the process group still stops the children
                run.publish(STOP_KEY, run.t, Stop(run.t, reason).to_message())
                run.wind_down()
            token.undeclare()
            flushes.undeclare()


def _inbox(session: zenoh.Session) -> Inbox:
    """What the supervisor listens to: the vehicles' steps, the broker's events and reports, every process token."""
    inbox = Inbox()
    inbox.subscribe(session, f"{ROOT}/vehicle/*/state")
    inbox.subscribe(session, done_key_pattern())  # each vehicle's count of what it dropped, at its end
    for key in (COMMS_EVENTS_KEY, COMMS_STATS_KEY, COMMS_DONE_KEY):  # not the batches: vehicles' business
        inbox.subscribe(session, key)
    inbox.watch_liveliness(session, f"{ALIVE_PREFIX}/**")
    return inbox


def _start(run: Supervisor, endpoint: str) -> None:
    """Start the broker and the vehicles (those started by hand: say how), and wait for every one to come alive
    running the supervisor's scenario."""
    run.spawn_comms()
    run.spawn_vehicles()
    bus = run.launch.bus
    if bus.remote:
        ids = ", ".join(str(v) for v in bus.remote)
        credentials = f" --credentials {bus.credentials_dir}/vehicle-N.json" if bus.credentials_dir else ""
        log.info(
            "start vehicle%s %s by hand: cpf vehicle %s --id N --connect %s%s (with this run's --set and --fault)",
            "s" if len(bus.remote) > 1 else "", ids, run.launch.path, reachable(bus.connect or endpoint), credentials,
        )  # fmt: skip
    run.await_alive()


def _drive(run: Supervisor, progress: Progress) -> None:
    """The run's steps, a time window per tick (supervisor.engine.windows; realtime: one step). In lockstep the next
    window's tick goes out as soon as this one's is out (ahead, so the broker starts it the moment the states of this
    window arrive, without a round trip through the supervisor), unless the vehicles' fresh reports could lengthen
    it; a tick that kills or restarts a process, and every realtime tick, waits for the states of the step before."""
    ticks, intake = run.clock, run.intake
    steps, dt = ticks.schedule.steps, ticks.schedule.dt
    for vid in run.alive:  # each steps from 0, every step once, in order (a step forged ahead of it is dropped)
        intake.expect(vid, 0)
    ticks.begin()
    progress.begin()
    a, b = 0, ticks.issue(run, 0)
    while a < steps:
        following, ahead_at = None, ticks.ahead_at(a, b)
        for k in range(a, b):
            if k == ahead_at and ticks.can_run_ahead(run, b):
                following = ticks.issue(run, b, ahead=True)
            run.t = k * dt
            ticks.record(run, k)
            waiting = lambda k=k: intake.waiting_for(k, run.alive)  # noqa: E731  # said if it stalls: who, and why
            run.wait_until(_all_stepped(run, k), waiting, STEP_TIMEOUT)
            intake.states.pop(k, None)  # none if no vehicle is left to report
            intake.window(k * dt, run.alive)  # taken once the broker's events of step k are in
            progress.update((k + 1) * dt)
        run.t = b * dt
        a, b = b, following if following is not None else ticks.issue(run, b)
    run.t = steps * dt
    _finish(run)


def _all_stepped(run: Supervisor, k: int) -> Callable[[], bool]:
    return lambda: run.intake.stepped(k, run.alive)


def _finish(run: Supervisor) -> None:
    """The broker's end-of-run report, every event it announced recorded; then nothing is left open."""
    if run.comms_up:
        run.wait_until(run.intake.books_closed, "the broker's end-of-run report", STEP_TIMEOUT)
    run.intake.close_open(run.t, "end_of_run")
    run.intake.window(run.t, run.alive)
    run.intake.close_windows()

"""The multi-process engine: the supervisor's side of a run over Eclipse Zenoh.

The supervisor opens a Zenoh router on a free localhost port (or the given endpoint), starts the broker and one
process per vehicle, waits for their liveliness tokens, then drives the clock: tick k (carrying every fault in force
over the step), wait for every live vehicle's state of step k, tick k+1, ... Lockstep runs as fast as the machine
allows; realtime paces the ticks to the wall clock. Everything on the bus is recorded to MCAP. Scheduled process
faults are carried out here (SIGKILL, restart from the last recorded state); a process that disappears is noticed
through its liveliness token and, for a vehicle, handled by scenario.on_vehicle_loss.
"""

from __future__ import annotations

import contextlib
import json
import logging
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from comms.bus import Inbox, Publishers, Received, decode_or_none, free_port, open_session
from comms.messages import (
    ALIVE_PREFIX,
    COMMS_ALIVE,
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    ROOT,
    STOP_END,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    TICK_KEY,
    Hello,
    Message,
    batches_message,
    event_message,
    parse_event,
    parse_events,
    rx_key,
    split_step,
    state_key,
    tick_lead,
    tick_message,
    tx_key,
    vehicle_alive_key,
    vehicle_of_key,
)
from comms.network import Network
from comms.records import Disturbances
from supervisor.analysis.series import SeriesBuilder
from supervisor.config.derived import steps_of
from supervisor.config.fleet import initial_state, link_stats, vehicle_config
from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_digest import section_digests
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.books import LinkBooks
from supervisor.engine.inprocess import RunResult
from supervisor.engine.metadata import graph_message, run_meta
from supervisor.engine.processes import ProcessGroup
from supervisor.engine.progress import Progress
from supervisor.engine.realtime_timing import RealtimeTiming
from supervisor.engine.startup import REPORT_EVERY, ask_hello, check_hello, missing_names
from supervisor.errors import SimulationError
from supervisor.plan.faults import ProcessAction, disturbances, events_at, network_at, process_actions
from supervisor.record.recorder import Recorder

START_TIMEOUT = 60.0  # s for a process to declare its liveliness token (cpf run --start-timeout)
STOP_DEADLINE = 3.0  # s for the processes to leave after the stop message, before the supervisor's token goes
log = logging.getLogger(__name__)
STEP_TIMEOUT = 60.0  # s for one sync step before the run is declared stuck
POLL_CHILDREN = 0.1  # s between checks of the children's exits (liveliness usually reports a death first)


class BusOptions:
    def __init__(
        self,
        listen: str | None = None,
        connect: str | None = None,
        remote: tuple[int, ...] = (),
        overrides: tuple[str, ...] = (),
        faults: tuple[str, ...] = (),
        start_timeout: float = START_TIMEOUT,
    ) -> None:
        self.listen = listen  # endpoint for the supervisor's router; default a free localhost port
        self.connect = connect  # join an existing router instead of being one
        self.remote = remote  # vehicles started by hand elsewhere: waited for, not spawned
        self.overrides = overrides  # --set KEY=VALUE, passed on to every child
        self.faults = faults  # --fault SPEC, passed on to every child
        self.start_timeout = start_timeout  # s for every process to come alive


class _Supervisor:
    """One run in progress: what is alive, what has arrived, what is recorded, what the links did."""

    def __init__(self, sc: Scenario, rec: Recorder, inbox: Inbox, procs: ProcessGroup, path: Path) -> None:
        self.sc, self.rec, self.inbox, self.procs, self.path = sc, rec, inbox, procs, path
        self.dt = sc.scenario.step
        self.builder = SeriesBuilder(sc.vehicle_ids, steps_of(sc), self.dt)
        self.books = LinkBooks(link_stats(sc))
        self.alive: list[int] = list(sc.vehicle_ids)
        self.comms_up = True
        self.present: set[str] = set()  # liveliness tokens seen and not gone
        self.expected: dict[str, str] = {}  # liveliness key -> process name, for every process the run needs
        self.states: dict[int, set[int]] = {}  # k -> vehicles whose state arrived
        self.last_state: dict[int, Message] = {}
        self.last_seq: dict[int, int] = {}
        self.done: Message | None = None
        self.broker_events = 0  # published by the current broker
        self.malformed = 0
        self.started = False
        self.t = 0.0
        self.connect = ""
        self.bus = BusOptions()
        self.seed = 0
        self._next_poll = 0.0
        self.clock: _Clock | None = None
        self.timing: RealtimeTiming | None = None  # realtime runs: how well they keep to the wall clock
        self.ask: Callable[[str], Hello | None] = lambda key: None  # a process's hello, by its liveliness key
        self.digests: dict[str, dict[str, str]] = {}  # "vehicle" / "comms": what their hellos must say (set_seed)

    # --- the bus -------------------------------------------------------------------------------------------

    def pump(self, timeout: float) -> None:
        item = self.inbox.get(timeout)
        if isinstance(item, str):
            self._liveliness(item)
        elif isinstance(item, Received):
            self._record(item)

    def set_seed(self, seed: int) -> None:
        """The run's seed, and so the digests every process must prove (the broker's covers the seed)."""
        self.seed = seed
        self.digests = {"vehicle": section_digests(self.sc), "comms": section_digests(self.sc, seed)}

    def wait_until(
        self, ready: Callable[[], bool], what: str | Callable[[], str], timeout: float, report: bool = False
    ) -> None:
        """Pump the bus until ready(); SimulationError after timeout s. what: what is waited for (a callable: worked
        out when it is said); report: say so every REPORT_EVERY s."""
        start = time.monotonic()
        end, next_report = start + timeout, start + REPORT_EVERY
        while not ready():
            now = time.monotonic()
            if now > end:
                raise SimulationError(f"timed out after {timeout:g} s waiting for {_say(what)}")
            if report and now >= next_report:
                next_report = now + REPORT_EVERY
                log.info("waiting for %s (%.0f s of %g s)", _say(what), now - start, timeout)
            if now >= self._next_poll:  # children's exits, at most every POLL_CHILDREN s: waitpid is not free
                self._next_poll = now + POLL_CHILDREN
                ended = self.procs.first_ended()
                if ended is not None:
                    self._lost(ended.name, ended.how_it_ended() or "")
            self.pump(min(0.2, max(0.0, end - now)))

    def _liveliness(self, change: str) -> None:
        sign, key = change[0], change[1:]
        if sign == "+":
            self.present.add(key)  # before the check: a refused process is still waited for to leave (wind_down)
            if key in self.expected:  # a process the run needs: it must run the supervisor's scenario
                kind = "comms" if key == COMMS_ALIVE else "vehicle"
                check_hello(self.expected[key], self.digests[kind], self.ask(key))
            return
        self.present.discard(key)
        if key in self.expected:
            child = self.procs.named(self.expected[key])
            how = child.how_it_ended() if child is not None else None
            self._lost(self.expected[key], how or "its liveliness token disappeared")

    def _lost(self, name: str, how: str) -> None:
        """A process the run needs is gone: go on without a vehicle if the scenario says so, else stop."""
        vid = int(name.split()[1]) if name.startswith("vehicle ") else None
        if vid is None or self.sc.scenario.on_vehicle_loss == "abort":
            when = f"at t = {self.t:.1f} s" if self.started else "before the start"
            raise SimulationError(f"{name} stopped {when} ({how})")
        print(f"cpf: warning: {name} lost at t = {self.t:.1f} s ({how}); going on without it", file=sys.stderr)
        self.alive = [i for i in self.alive if i != vid]
        self.expected.pop(vehicle_alive_key(vid), None)
        self.procs.forget(name)
        if self.clock is not None:
            self.clock.reissue()

    def _record(self, item: Received) -> None:
        message = decode_or_none(item.payload)
        if message is None:
            self.malformed += 1
            return
        owned = vehicle_of_key(item.key)
        if owned is not None and owned[1] == "state":
            self._step(owned[0], message)
        elif item.key == COMMS_EVENTS_KEY:
            self._events(message)
        else:
            self._write(item.key, message)
            if item.key == COMMS_DONE_KEY:
                self.done = message

    def _write(self, key: str, message: Message) -> None:
        t = message.get("t")
        self.rec.write(key, t if isinstance(t, int | float) else self.t, message)

    def _step(self, vid: int, message: Message) -> None:
        """A vehicle's step message, recorded as the log keeps it: reception batch, transmission, state."""
        state, tx, rx = split_step(message)
        if self.timing is not None:
            self.timing.add_state(state)
            if rx is not None:
                self.timing.add_rx(rx)
        if rx is not None:
            self._write(rx_key(vid), rx)
        if tx is not None:
            self._write(tx_key(vid), tx)
        self._write(state_key(vid), state)
        if isinstance(state.get("k"), int):
            self._state(vid, state)

    def _state(self, vid: int, message: Message) -> None:
        self.builder.add(message)
        self.states.setdefault(message["k"], set()).add(vid)
        self.last_state[vid] = message
        if message.get("tx_seq"):
            self.last_seq[vid] = message["tx_seq"]

    def _events(self, batch: Message) -> None:
        """A step's link events: one log record each; a malformed one is recorded but not booked."""
        try:
            events = parse_events(batch)
        except ValueError:
            self.malformed += 1
            return
        self.broker_events += len(events)
        booked = []
        for message in events:
            self._write(COMMS_EVENT_KEY, message)
            with contextlib.suppress(ValueError):
                booked.append(parse_event(message))
        self.books.add(booked)

    def publish(self, pubs: Publishers, key: str, t: float, message: Message) -> None:
        pubs.put(key, message)
        self.rec.write(key, t, message)

    # --- processes ---------------------------------------------------------------------------------------

    def spawn_comms(self, start_step: int = 0) -> None:
        self.expected[COMMS_ALIVE] = "comms broker"
        extra = ["--seed", str(self.seed), "--start-step", str(start_step)]
        self.procs.spawn("comms broker", self._argv("comms", *extra))
        self.broker_events, self.done = 0, None

    def spawn_vehicle(self, vid: int, resume: list[str] | None = None) -> None:
        self.expected[vehicle_alive_key(vid)] = f"vehicle {vid}"
        if vid not in self.bus.remote:
            start = resume or self._gamma0(vid)
            self.procs.spawn(f"vehicle {vid}", self._argv("vehicle", "--id", str(vid), *start))

    def _gamma0(self, vid: int) -> list[str]:
        """The vehicle's initial gamma, resolved here once: a child then never searches its path for the nearest
        point (and never imports scipy for it), which makes a large fleet start much faster."""
        index = self.sc.vehicle_ids.index(vid)
        if self.sc.vehicles[index].gamma0 != "closest":
            return []
        gamma0 = initial_state(self.sc, vehicle_config(self.sc, vid)).gamma
        return ["--gamma0", repr(gamma0)]  # not a --set: the vehicle's scenario (and digest) stays the supervisor's

    def _argv(self, command: str, *extra: str) -> list[str]:
        sets = [arg for override in self.bus.overrides for arg in ("--set", override)]
        faults = [arg for fault in self.bus.faults for arg in ("--fault", fault)]
        base = [sys.executable, "-m", "supervisor.cli", command, str(self.path), "--connect", self.connect]
        return [*base, *sets, *faults, *extra]

    def missing(self) -> list[str]:
        """The processes the run needs whose liveliness token is not (or no longer) there."""
        return [self.expected[key] for key in sorted(set(self.expected) - self.present)]

    def await_alive(self) -> None:
        """Wait for every process the run needs, naming the missing ones every few seconds."""
        what = lambda: f"{missing_names(self.missing(), self.bus.remote)} to come alive"  # noqa: E731
        self.wait_until(lambda: not self.missing(), what, self.bus.start_timeout, report=True)

    def wind_down(self, deadline: float = STOP_DEADLINE) -> None:
        """After the stop message: wait (a while) for the processes to leave, so that none sees the supervisor
        go before its stop message (it would report the supervisor gone; the token's end can overtake the
        message)."""
        self.expected.clear()  # leaving is what they are asked to do now, not a loss
        end = time.monotonic() + deadline
        while self.present & _process_tokens(self.sc) and time.monotonic() < end:
            self.pump(0.05)

    def carry_out(self, action: ProcessAction, k: int, pubs: Publishers, resume_dir: Path) -> None:
        """A scheduled kill or restart: the schedule is the fault, not a loss, so the run goes on whatever
        scenario.on_vehicle_loss says (that is for deaths nobody scheduled)."""
        if action.action == "kill":
            if self._kill(action.name):
                action.announce(self.t)
        elif action.target == "comms":
            self.spawn_comms(start_step=k)
            self.await_alive()
            self.comms_up = True
            action.announce(self.t)
        elif action.vehicle is not None and action.vehicle not in self.alive:
            self._restart_vehicle(action.vehicle, k, resume_dir)
            action.announce(self.t, float(self.last_state[action.vehicle]["t"]))

    def _kill(self, name: str) -> bool:
        """SIGKILL to a process this supervisor started, its going awaited; False if there is none to kill."""
        child = self.procs.named(name)
        if child is None:
            print(f"cpf: warning: cannot kill {name}: not started by this supervisor", file=sys.stderr)
            return False
        vid = None if name == "comms broker" else int(name.split()[1])
        key = COMMS_ALIVE if vid is None else vehicle_alive_key(vid)
        self.expected.pop(key, None)  # its going is the fault itself, not a failure of the run
        child.kill()
        self.procs.forget(name)
        self.wait_until(lambda: key not in self.present, f"{name} to be noticed gone", START_TIMEOUT)
        if vid is None:
            self.comms_up = False
            self._close_open("broker_down")
        else:
            self.alive = [i for i in self.alive if i != vid]
        return True

    def _restart_vehicle(self, vid: int, k: int, resume_dir: Path) -> None:
        state_file = resume_dir / f"vehicle-{vid}.json"
        state_file.write_text(json.dumps(self.last_state[vid]))
        resume = ["--resume", str(state_file), "--start-step", str(k), "--resume-seq", str(self.last_seq.get(vid, 0))]
        self.spawn_vehicle(vid, resume)
        self.await_alive()
        self.alive = sorted([*self.alive, vid])

    def _close_open(self, reason: str) -> None:
        events = self.books.close_open(self.t, reason)
        self.books.add(events)
        for event in events:
            self.rec.write(COMMS_EVENT_KEY, event.t, event_message(event))


def _reachable(endpoint: str) -> str:
    """How another host names an endpoint the supervisor listens on (an unspecified address: any of this host's)."""
    return endpoint.replace("0.0.0.0", "<this host>").replace("[::]", "<this host>")


def _say(what: str | Callable[[], str]) -> str:
    return what if isinstance(what, str) else what()


def _process_tokens(sc: Scenario) -> set[str]:
    return {COMMS_ALIVE, *(vehicle_alive_key(v) for v in sc.vehicle_ids)}


def _local(endpoint: str) -> str:
    """How processes on this machine reach an endpoint the supervisor listens on."""
    return endpoint.replace("0.0.0.0", "127.0.0.1").replace("[::]", "[::1]")


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
) -> RunResult:
    """Run the scenario over Zenoh with one process per vehicle and a broker; record everything to out."""
    if load_scenario(scenario_path, bus.overrides, bus.faults) != scenario:  # what every child process will load
        raise ValueError(f"run_zenoh: the scenario is not {scenario_path} with bus.overrides and bus.faults")
    endpoint = bus.listen or f"tcp/127.0.0.1:{free_port()}"
    mode, listen, connect = ("client", [], [bus.connect]) if bus.connect else ("router", [endpoint], [])
    steps = steps_of(scenario)
    with (
        open_session(mode, listen, connect) as session,
        Recorder(out) as rec,
        ProcessGroup() as procs,
        tempfile.TemporaryDirectory(prefix="cpf-resume-") as resume_dir,
    ):
        inbox = Inbox()
        inbox.subscribe(session, f"{ROOT}/vehicle/*/state")
        for key in (COMMS_EVENTS_KEY, COMMS_STATS_KEY, COMMS_DONE_KEY):  # not the batches: vehicles' business
            inbox.subscribe(session, key)
        inbox.watch_liveliness(session, f"{ALIVE_PREFIX}/**")
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)
        pubs = Publishers(session)
        run = _Supervisor(scenario, rec, inbox, procs, scenario_path)
        run.connect, run.bus = bus.connect or _local(endpoint), bus
        run.set_seed(seed)
        run.ask = lambda key: ask_hello(session, key)
        run.timing = RealtimeTiming(scenario.scenario.step) if clock == "realtime" else None
        # In the log from the start: a run that never starts (a process missing or refused) still says what it was.
        meta = run_meta(scenario, str(scenario_path), scenario_toml, seed, "zenoh", clock)
        rec.write(META_KEY, 0.0, meta)
        reason = STOP_END
        try:
            _start(run, endpoint)
            pubs.put(META_KEY, meta)
            run.publish(pubs, GRAPH_KEY, 0.0, graph_message(0.0, scenario.graph.edges))
            _drive(run, pubs, steps, clock, speed, progress, Path(resume_dir))
        except BaseException as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise
        finally:
            with contextlib.suppress(Exception):  # already failing: the process group still stops the children
                run.publish(pubs, STOP_KEY, run.t, {"t": run.t, "reason": reason})
                run.wind_down()
            token.undeclare()
        stepping = progress.stepping_time()
        wall = progress.done(steps * scenario.scenario.step)
        messages = rec.count
    books = run.books
    end = steps * scenario.scenario.step
    return RunResult(
        run.builder.series(), wall, messages, books.counts, books.stats.snapshot(end), books.lambda2, run.builder.ages,
        stepping, run.timing.as_dict() if run.timing is not None else None,
    )  # fmt: skip


def _start(run: _Supervisor, endpoint: str) -> None:
    """Start the broker and the vehicles (those started by hand: say how), and wait for every one to come alive
    running the supervisor's scenario."""
    run.spawn_comms()
    for vid in run.sc.vehicle_ids:
        run.spawn_vehicle(vid)
    if run.bus.remote:
        ids = ", ".join(str(v) for v in run.bus.remote)
        log.info(
            "start vehicles %s by hand: cpf vehicle %s --id N --connect %s (with this run's --set and --fault)",
            ids, run.path, _reachable(run.bus.connect or endpoint),
        )  # fmt: skip
    run.await_alive()


class _Clock:
    """Issues the ticks: what is in force over each step, with the faults and process actions due then."""

    def __init__(self, run: _Supervisor, pubs: Publishers, clock: str, speed: float, resume_dir: Path) -> None:
        self.run, self.pubs, self.clock, self.speed, self.resume_dir = run, pubs, clock, speed, resume_dir
        self.edges = run.sc.graph.edges
        self.usual = Network(tuple((a, b) for a, b in self.edges))  # the scenario's graph, no link faults
        self.wall_start, self.epoch_start = time.monotonic(), time.time()  # pacing; the wall clock processes share
        self.lead = tick_lead(run.dt, speed)
        self.issued: Message | None = None
        self.ahead = False  # the latest tick went out before every state of the step before it was in
        self._actions: dict[int, list[ProcessAction]] = {}  # by step: each is asked for at k-1 (hold), ahead, at k

    def actions(self, k: int) -> list[ProcessAction]:
        """Kills and restarts due at step k."""
        if k not in self._actions:
            self._actions = {k: process_actions(self.run.sc.faults, k * self.run.dt, self.run.dt)}  # keep only k
        return self._actions[k]

    def can_run_ahead(self, k: int) -> bool:
        """Tick k may go out before the states of step k-1 are in: lockstep, and no kill or restart due at k."""
        return self.clock == "lockstep" and not self.actions(k)

    def issue(self, k: int, final: bool, ahead: bool = False) -> None:
        run, sc, dt = self.run, self.run.sc, self.run.dt
        t, self.ahead = k * dt, ahead
        if self.clock == "realtime":
            _pace(run, self.wall_start + t / self.speed - self.lead)
        if not final:
            for event in events_at(sc.faults, t, dt):
                run.publish(self.pubs, FAULT_KEY, t, event.message())
            for action in self.actions(k):
                run.carry_out(action, k, self.pubs, self.resume_dir)
        network = network_at(sc, t, dt)
        if network.edges != self.edges and not final:
            self.edges = network.edges
            run.publish(self.pubs, GRAPH_KEY, t, graph_message(t, self.edges))
        self._publish(k, t, final, network)

    def _publish(self, k: int, t: float, final: bool, network: Network) -> None:
        run, sc = self.run, self.run.sc
        disturbed = {i: d for i in run.alive if (d := disturbances(sc.faults, i, t, run.dt)) != Disturbances()}
        wall = self.epoch_start + t / self.speed if self.clock == "realtime" else None
        # The common case in its short form (null: the scenario's graph without link faults, every vehicle alive):
        # every process parses every tick, and with a large fleet the long form costs more than the step itself.
        spelt = None if network == self.usual else network
        alive = None if len(run.alive) == len(sc.vehicle_ids) else list(run.alive)  # alive: a subset of the ids
        hold = not final and bool(self.actions(k + 1))
        self.issued = tick_message(k, t, final, disturbed, spelt, alive, run.comms_up, wall, self.speed, hold)
        run.publish(self.pubs, TICK_KEY, t, self.issued)
        if not run.comms_up and not final:  # no broker to hand the vehicles their tick: no receptions either
            self.pubs.put(COMMS_STEP_KEY, batches_message(self.issued, None))

    def reissue(self) -> None:
        """A vehicle was lost after the latest tick went out ahead counting it alive: say it again without it, or
        the broker would wait for that vehicle's state forever."""
        tick = self.issued
        if tick is not None and self.ahead:
            k = int(tick["k"])
            self._publish(k, tick["t"], bool(tick["final"]), network_at(self.run.sc, tick["t"], self.run.dt))


def _drive(
    run: _Supervisor, pubs: Publishers, steps: int, clock: str, speed: float, progress: Progress, resume_dir: Path
) -> None:
    """The clock. In lockstep, tick k+1 goes out as soon as the states of step k-1 are in (one step ahead, so the
    broker starts step k+1 the moment the states of step k arrive, without a round trip through the supervisor);
    a tick that kills or restarts a process, and every realtime tick, waits for the states of the step before."""
    run.started = True
    progress.begin()
    ticks = run.clock = _Clock(run, pubs, clock, speed, resume_dir)
    ticks.issue(0, final=steps == 0)
    for k in range(steps):
        run.t = k * run.dt
        ahead = ticks.can_run_ahead(k + 1)
        if ahead:
            ticks.issue(k + 1, final=k + 1 == steps, ahead=True)
        run.wait_until(_all_stepped(run, k), f"every vehicle's state of step {k}", STEP_TIMEOUT)
        run.states.pop(k, None)  # none if no vehicle is left to report
        run.books.window(k * run.dt)  # the broker's events of tick k came before the batches the vehicles stepped on
        progress.update((k + 1) * run.dt)
        if not ahead:
            run.t = (k + 1) * run.dt
            ticks.issue(k + 1, final=k + 1 == steps)
    run.t = steps * run.dt
    _finish(run)


def _finish(run: _Supervisor) -> None:
    """The broker's end-of-run report, every event it announced recorded; then nothing is left open."""
    if run.comms_up:
        run.wait_until(lambda: _books_closed(run), "the broker's end-of-run report", STEP_TIMEOUT)
    run._close_open("end_of_run")
    run.books.window(run.t)
    if run.malformed:
        print(f"cpf: warning: {run.malformed} malformed messages on the bus were dropped", file=sys.stderr)


def _all_stepped(run: _Supervisor, k: int) -> Callable[[], bool]:
    return lambda: all(v in run.states.get(k, ()) for v in run.alive)


def _books_closed(run: _Supervisor) -> bool:
    done = run.done
    return done is not None and run.broker_events >= int(done.get("events", 0))


def _pace(run: _Supervisor, target: float) -> None:
    """Realtime clock: keep recording until the wall clock reaches the tick's time."""
    while (left := target - time.monotonic()) > 0:
        run.pump(min(left, 0.05))

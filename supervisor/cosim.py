"""The multi-process engine: the supervisor's side of a run over Eclipse Zenoh.

The supervisor opens a Zenoh router on a free localhost port (or the given endpoint), starts the broker and one
process per vehicle, waits for their liveliness tokens, then drives the clock: tick k, wait for every vehicle's state
of step k, tick k+1, ... Lockstep runs as fast as the machine allows; realtime paces the ticks to the wall clock.
Everything on the bus is recorded to MCAP. A child whose token disappears stops the run with a clear message.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from comms.bus import Inbox, Publishers, Received, decode_or_none, free_port, open_session
from comms.messages import (
    ALIVE_PREFIX,
    COMMS_ALIVE,
    COMMS_DONE_KEY,
    COMMS_EVENT_KEY,
    COMMS_STATS_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    ROOT,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    TICK_KEY,
    Message,
    tick_message,
    vehicle_alive_key,
    vehicle_of_key,
)
from supervisor.errors import SimulationError
from supervisor.faults import disturbances, events_at
from supervisor.inprocess import RunResult
from supervisor.metadata import graph_message, run_meta
from supervisor.processes import ProcessGroup
from supervisor.progress import Progress
from supervisor.recorder import Recorder
from supervisor.scenario_schema import Scenario
from supervisor.series import SeriesBuilder

START_TIMEOUT = 60.0  # s for every process to declare its liveliness token
STEP_TIMEOUT = 60.0  # s for one sync step before the run is declared stuck


@dataclass(frozen=True, slots=True)
class BusOptions:
    listen: str | None = None  # endpoint for the supervisor's router; default a free localhost port
    connect: str | None = None  # join an existing router instead of being one
    remote: tuple[int, ...] = ()  # vehicles started by hand elsewhere: waited for, not spawned
    overrides: tuple[str, ...] = ()  # --set KEY=VALUE, passed on to every child


@dataclass
class _Books:
    alive: set[str] = field(default_factory=set)
    expected: dict[str, str] = field(default_factory=dict)  # liveliness key -> process name
    states: dict[int, int] = field(default_factory=dict)  # k -> states received
    events: dict[str, int] = field(default_factory=lambda: {"sent": 0, "delivered": 0, "dropped": 0})
    done: Message | None = None
    stats: list[Message] = field(default_factory=list)
    malformed: int = 0
    started: bool = False
    t: float = 0.0


class _Supervisor:
    """The state of one run in progress: what has arrived, what is alive, what is recorded."""

    def __init__(self, rec: Recorder, inbox: Inbox, procs: ProcessGroup, builder: SeriesBuilder) -> None:
        self.rec, self.inbox, self.procs, self.builder = rec, inbox, procs, builder
        self.books = _Books()

    def pump(self, timeout: float) -> None:
        """Take in one item from the bus (or wait up to timeout)."""
        item = self.inbox.get(timeout)
        if isinstance(item, str):
            self._liveliness(item)
        elif isinstance(item, Received):
            self._record(item)

    def wait_until(self, ready: Callable[[], bool], what: str, timeout: float) -> None:
        end = time.monotonic() + timeout
        while not ready():
            if time.monotonic() > end:
                raise SimulationError(f"timed out after {timeout:.0f} s waiting for {what}")
            ended = self.procs.first_ended()
            if ended is not None:
                raise self._gone(ended.name, ended.how_it_ended() or "")
            self.pump(min(0.2, max(0.0, end - time.monotonic())))

    def _liveliness(self, change: str) -> None:
        sign, key = change[0], change[1:]
        if sign == "+":
            self.books.alive.add(key)
        elif key in self.books.expected:
            self.books.alive.discard(key)
            name = self.books.expected[key]
            child = self.procs.named(name)
            how = child.how_it_ended() if child is not None else None
            raise self._gone(name, how or "its liveliness token disappeared")

    def _gone(self, name: str, how: str) -> SimulationError:
        """The one message for a process lost during a run, whichever way it was noticed."""
        when = f"at t = {self.books.t:.1f} s" if self.books.started else "before the start"
        return SimulationError(f"{name} stopped {when} ({how})")

    def _record(self, item: Received) -> None:
        message = decode_or_none(item.payload)
        if message is None:
            self.books.malformed += 1
            return
        t = message.get("t")
        self.rec.write(item.key, t if isinstance(t, int | float) else self.books.t, message)
        owned = vehicle_of_key(item.key)
        if owned is not None and owned[1] == "state" and isinstance(message.get("k"), int):
            self.builder.add(message)
            self.books.states[message["k"]] = self.books.states.get(message["k"], 0) + 1
        elif item.key == COMMS_EVENT_KEY and message.get("kind") in self.books.events:
            self.books.events[message["kind"]] += 1
        elif item.key == COMMS_DONE_KEY:
            self.books.done = message
        elif item.key == COMMS_STATS_KEY:
            self.books.stats.append(message)


def _child_argv(command: str, scenario_path: Path, connect: str, *extra: str) -> list[str]:
    return [sys.executable, "-m", "supervisor.cli", command, str(scenario_path), "--connect", connect, *extra]


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
    endpoint = bus.listen or f"tcp/127.0.0.1:{free_port()}"
    mode, listen, connect = ("client", [], [bus.connect]) if bus.connect else ("router", [endpoint], [])
    children_connect = bus.connect or _local(endpoint)
    dt, steps, ids = (
        scenario.scenario.step,
        round(scenario.scenario.duration / scenario.scenario.step),
        scenario.vehicle_ids,
    )
    builder = SeriesBuilder(ids, steps, dt)
    with open_session(mode, listen, connect) as session, Recorder(out) as rec, ProcessGroup() as procs:
        inbox = Inbox()
        inbox.subscribe(session, f"{ROOT}/vehicle/**")
        inbox.subscribe(session, f"{ROOT}/comms/**")
        inbox.watch_liveliness(session, f"{ALIVE_PREFIX}/**")
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)
        pubs = Publishers(session)
        run = _Supervisor(rec, inbox, procs, builder)
        try:
            _start(run, scenario, scenario_path, children_connect, seed, bus)
            _publish(
                pubs, rec, META_KEY, 0.0, run_meta(scenario, str(scenario_path), scenario_toml, seed, "zenoh", clock)
            )
            _publish(pubs, rec, GRAPH_KEY, 0.0, graph_message(0.0, scenario.graph.edges))
            _drive(run, pubs, scenario, steps, clock, speed, progress)
        finally:
            _stop_children(pubs, rec, run.books.t)
            token.undeclare()
        wall = progress.done(steps * dt)
        messages = rec.count
    stats = run.books.stats
    last = stats[-1] if stats else None
    return RunResult(builder.series(), wall, messages, dict(run.books.events), last, stats, builder.ages)


def _start(run: _Supervisor, scenario: Scenario, path: Path, connect: str, seed: int, bus: BusOptions) -> None:
    """Start the broker and the vehicles, and wait until every one has declared its liveliness token."""
    sets = [arg for override in bus.overrides for arg in ("--set", override)]
    run.books.expected[COMMS_ALIVE] = "comms broker"
    run.procs.spawn("comms broker", _child_argv("comms", path, connect, "--seed", str(seed), *sets))
    for vid in scenario.vehicle_ids:
        run.books.expected[vehicle_alive_key(vid)] = f"vehicle {vid}"
        if vid not in bus.remote:
            run.procs.spawn(f"vehicle {vid}", _child_argv("vehicle", path, connect, "--id", str(vid), *sets))
    missing = lambda: sorted(set(run.books.expected) - run.books.alive)  # noqa: E731
    run.wait_until(lambda: not missing(), "every process to come alive", START_TIMEOUT)


def _drive(
    run: _Supervisor, pubs: Publishers, scenario: Scenario, steps: int, clock: str, speed: float, progress: Progress
) -> None:
    """The clock: one tick per sync step, each waiting for every vehicle's state; then the final tick."""
    dt, ids = scenario.scenario.step, scenario.vehicle_ids
    run.books.started = True
    wall_start = time.monotonic()
    for k in range(steps + 1):
        t = k * dt
        run.books.t = t
        if clock == "realtime":
            _pace(run, wall_start + t / speed)
        final = k == steps
        if not final:
            for event in events_at(scenario.faults, t, dt):
                _publish(pubs, run.rec, FAULT_KEY, t, event.message())
        caps = {i: c for i in ids if (c := disturbances(scenario.faults, i, t, dt).gamma_dot_cap) is not None}
        _publish(pubs, run.rec, TICK_KEY, t, tick_message(k, t, final, caps))
        if final:
            run.wait_until(lambda: _books_closed(run), "the broker's end-of-run report", STEP_TIMEOUT)
        else:
            stepped = _all_stepped(run, k, len(ids))
            run.wait_until(stepped, f"every vehicle's state of step {k}", STEP_TIMEOUT)
            progress.update(t + dt)


def _all_stepped(run: _Supervisor, k: int, n: int) -> Callable[[], bool]:
    return lambda: run.books.states.get(k, 0) >= n


def _books_closed(run: _Supervisor) -> bool:
    done = run.books.done
    return done is not None and sum(run.books.events.values()) >= int(done.get("events", 0))


def _pace(run: _Supervisor, target: float) -> None:
    """Realtime clock: keep recording until the wall clock reaches the tick's time."""
    while (left := target - time.monotonic()) > 0:
        run.pump(min(left, 0.05))


def _stop_children(pubs: Publishers, rec: Recorder, t: float) -> None:
    """Ask every child to stop; ProcessGroup enforces it with signals if they do not."""
    with contextlib.suppress(Exception):  # already failing: the process group still stops the children
        _publish(pubs, rec, STOP_KEY, t, {"t": t, "reason": "end of run"})


def _publish(pubs: Publishers, rec: Recorder, key: str, t: float, message: Message) -> None:
    pubs.put(key, message)
    rec.write(key, t, message)

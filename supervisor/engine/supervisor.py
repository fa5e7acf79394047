"""The Zenoh supervisor of one run in progress: who is alive, the bus pumped into its intake, and its processes
started, waited for, killed and restarted.

A process the run needs that disappears is noticed through its liveliness token (or its exit); a lost vehicle is
handled by scenario.on_vehicle_loss. Scheduled kills and restarts (supervisor.plan) are the fault itself, not a loss.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from comms.bus.bus import Inbox, Publishers, Received
from comms.records.messages import COMMS_ALIVE, Message, vehicle_alive_key
from supervisor.config.broker_start import broker_start
from supervisor.config.scenario_schema import Scenario
from supervisor.config.vehicle_start import Resume, vehicle_starts
from supervisor.engine import interrupts
from supervisor.engine.clock import Clock
from supervisor.engine.hosting import cores, default_per_process, groups, host_name, hosted_ids, hosts_chosen
from supervisor.engine.intake import Intake
from supervisor.engine.launch import START_TIMEOUT, Launch
from supervisor.engine.startup import REPORT_EVERY, Hellos, missing_names
from supervisor.engine.windows import Reports
from supervisor.errors import SimulationError
from supervisor.plan.faults import ProcessAction
from supervisor.processes import Child, ProcessGroup
from vehicles.host import CONTROL_ENV

STOP_DEADLINE = 3.0  # s for the processes to leave after the stop message, before the supervisor's token goes
POLL_CHILDREN = 0.1  # s between checks of the children's exits (liveliness usually reports a death first)
LAST_WORDS_GRACE = 1.0  # s a process whose token went is given to end, so its exit says why
log = logging.getLogger("cpf.engine")


@dataclass
class Roster:
    """The processes the run needs, by liveliness key, and the tokens on the bus."""

    expected: dict[str, str] = field(default_factory=dict)  # liveliness key -> process name
    present: set[str] = field(default_factory=set)  # liveliness tokens seen and not gone

    def missing(self) -> list[str]:
        """The processes the run needs whose liveliness token is not (or no longer) there."""
        return [self.expected[key] for key in sorted(set(self.expected) - self.present)]


class Supervisor:
    """One run in progress: what is alive, what has arrived (intake), which processes it runs (roster)."""

    def __init__(
        self,
        sc: Scenario,
        *,
        bus: tuple[Inbox, Publishers],
        procs: ProcessGroup,
        launch: Launch,
        hellos: Hellos,
        intake: Intake,
        clock: Clock,
    ) -> None:
        self.sc, (self.inbox, self.pubs), self.procs, self.launch, self.hellos = sc, bus, procs, launch, hellos
        self.intake, self.clock = intake, clock
        self.roster = Roster()
        self.hosted: dict[int, str] = {}  # vehicle -> the name of the host process serving it (vehicles.host)
        self.alive: list[int] = list(sc.vehicle_ids)
        self.comms_up = True
        self.t = 0.0
        self._next_poll = 0.0

    # --- the bus -------------------------------------------------------------------------------------------

    def pump(self, timeout: float) -> None:
        interrupts.check()  # every wait on the bus goes through here: where a run stops on Ctrl-C
        item = self.inbox.get(timeout)
        if isinstance(item, str):
            self._liveliness(item)
        elif isinstance(item, Received):
            self.intake.take(item, self.t)

    def publish(self, key: str, t: float, message: Message) -> None:
        self.intake.publish(self.pubs, key, t, message)

    def grant(self, reach: int) -> None:
        self.intake.granted = max(self.intake.granted or 0, reach)

    def record(self, key: str, t: float, message: Message) -> None:
        """On the record only: what the log keeps of a message that went on the bus in another form."""
        self.intake.rec.write(key, t, message)

    @property
    def reports(self) -> Reports:
        """Each vehicle's latest step reported and the first step at which it may transmit next."""
        return self.intake.next_tx

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
            for vid, why in self.intake.new_faults():
                self._faulty(vid, why)

    def _faulty(self, vid: int, why: str) -> None:
        """A vehicle sent a state that is its fault (not finite, implausible: dropped and counted): the run stops,
        naming it, or, if the scenario goes on without a lost vehicle, its process is stopped (it would go on stepping
        and transmitting, each message dropped) and the run goes on without it."""
        if vid not in self.alive:
            return
        if self.sc.scenario.on_vehicle_loss == "abort":
            raise SimulationError(f"vehicle {vid} sent a state the run cannot use at t = {self.t:.1f} s ({why})")
        name, how = f"vehicle {vid}", f"it sent a state the run cannot use: {why}"
        if self._process_of(name) is None:  # not this supervisor's to stop (a remote vehicle)
            self._lost(name, how)
            return
        log.warning("%s lost at t = %.1f s (%s); going on without it", name, self.t, how)
        self._kill(name)
        self.clock.reissue(self)

    def _liveliness(self, change: str) -> None:
        sign, key = change[0], change[1:]
        expected = self.roster.expected
        if sign == "+":
            self.roster.present.add(key)  # before the check: a refused process is still waited for to leave
            if key in expected:  # a process the run needs: it must run the supervisor's scenario
                self.hellos.check(key, expected[key])
            return
        self.roster.present.discard(key)
        if key in expected:
            child = self._process_of(expected[key])
            # Its token goes as its session closes, a moment before the process ends: its last words say why.
            how = child.how_it_ended(grace=LAST_WORDS_GRACE) if child is not None else None
            self._lost(expected[key], how or "its liveliness token disappeared")

    def _lost(self, name: str, how: str) -> None:
        """A process the run needs is gone: go on without a vehicle if the scenario says so, else stop. A host's
        death loses each vehicle it still served, and the scenario decides for each."""
        members = hosted_ids(name)
        if members is not None:
            self.procs.forget(name)
            for member in members:
                if self.hosted.get(member) == name:
                    self._lost(f"vehicle {member}", how)
            return
        vid = int(name.split()[1]) if name.startswith("vehicle ") else None
        if vid is None or self.sc.scenario.on_vehicle_loss == "abort":
            when = f"at t = {self.t:.1f} s" if self.clock.begun else "before the start"
            raise SimulationError(f"{name} stopped {when} ({how})")
        log.warning("%s lost at t = %.1f s (%s); going on without it", name, self.t, how)
        self.alive = [i for i in self.alive if i != vid]
        self.roster.expected.pop(vehicle_alive_key(vid), None)
        if vid in self.hosted:
            self._unhost(vid)
        else:
            self.procs.forget(name)
        self.clock.reissue(self)

    # --- processes ---------------------------------------------------------------------------------------

    def spawn_comms(self, start_step: int = 0) -> None:
        self.roster.expected[COMMS_ALIVE] = "comms broker"
        handed = self.launch.handover("comms broker", broker_start(self.sc, self.launch.seed))
        extra = ["--seed", str(self.launch.seed), "--start-step", str(start_step), *handed]
        self.procs.spawn("comms broker", self.launch.argv("comms", *extra))
        self.intake.broker_started()

    def spawn_vehicles(self) -> None:
        """Every vehicle of the scenario: those started by hand awaited, the others in processes of
        --vehicles-per-process (by default, supervisor.engine.hosting: one each unless the fleet is large)."""
        local = [v for v in self.sc.vehicle_ids if v not in self.launch.bus.remote]
        per_process = self.launch.bus.per_process
        if per_process is None:
            per_process = default_per_process(len(local), cores())
            if per_process > 1:
                log.info("%s", hosts_chosen(len(local), cores(), per_process))
        for vid in self.launch.bus.remote:
            self.spawn_vehicle(vid)
        for group in groups(local, per_process):
            if len(group) == 1:
                self.spawn_vehicle(group[0])
            else:
                self.spawn_host(group)

    def spawn_host(self, vids: tuple[int, ...]) -> None:
        """One process serving vehicles vids (vehicles.host), each on its own session, as if alone."""
        name = host_name(vids)
        for vid in vids:
            self.roster.expected[vehicle_alive_key(vid)] = f"vehicle {vid}"
            self.hosted[vid] = name
        ids = [arg for vid in vids for arg in ("--id", str(vid))]
        handed = self.launch.handover(name, vehicle_starts(self.sc, vids, seed=self.launch.seed))
        self.procs.spawn(name, self.launch.argv("vehicle", *ids, *handed), CONTROL_ENV)

    def spawn_vehicle(self, vid: int, resume: Resume | None = None, k: int = 0) -> None:
        """Vehicle vid in a process of its own (resume: restarted at step k), or awaited if started by hand."""
        self.roster.expected[vehicle_alive_key(vid)] = f"vehicle {vid}"
        if vid not in self.launch.bus.remote:
            name = f"vehicle {vid}"
            handed = self.launch.handover(
                name, vehicle_starts(self.sc, [vid], resume=resume, start_step=k, seed=self.launch.seed)
            )
            self.procs.spawn(name, self.launch.argv("vehicle", "--id", str(vid), *handed))

    def await_alive(self) -> None:
        """Wait for every process the run needs, naming the missing ones every few seconds."""
        what = lambda: f"{missing_names(self.roster.missing(), self.launch.bus.remote)} to come alive"  # noqa: E731
        self.wait_until(lambda: not self.roster.missing(), what, self.launch.bus.start_timeout, report=True)

    def wind_down(self, deadline: float = STOP_DEADLINE) -> None:
        """After the stop message: wait (a while) for the processes to leave, so that none sees the supervisor
        go before its stop message (it would report the supervisor gone; the token's end can overtake the
        message)."""
        self.roster.expected.clear()  # leaving is what they are asked to do now, not a loss
        tokens = {COMMS_ALIVE, *(vehicle_alive_key(v) for v in self.sc.vehicle_ids)}
        # Each vehicle still there reports what it dropped as it leaves; its token's end can overtake the report.
        reporting = [v for v in self.sc.vehicle_ids if vehicle_alive_key(v) in self.roster.present]
        end = time.monotonic() + deadline
        while time.monotonic() < end and (
            self.roster.present & tokens or any(v not in self.intake.vehicles_done for v in reporting)
        ):
            self.pump(0.05)

    def carry_out(self, action: ProcessAction, k: int) -> None:
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
            self._restart_vehicle(action.vehicle, k)
            action.announce(self.t, float(self.intake.last_state[action.vehicle]["t"]))

    def _kill(self, name: str) -> bool:
        """SIGKILL to a process this supervisor started, its going awaited; False if there is none to kill."""
        child = self._process_of(name)
        if child is None:
            log.warning("cannot kill %s: not started by this supervisor", name)
            return False
        vid = None if name == "comms broker" else int(name.split()[1])
        key = COMMS_ALIVE if vid is None else vehicle_alive_key(vid)
        self.roster.expected.pop(key, None)  # its going is the fault itself, not a failure of the run
        if vid is not None and vid in self.hosted:
            child.tell(f"kill {vid}")  # its host stops serving it alone (vehicles.host), as its own SIGKILL would
            self._unhost(vid)
        else:
            child.kill()
            self.procs.forget(name)
        self.wait_until(lambda: key not in self.roster.present, f"{name} to be noticed gone", START_TIMEOUT)
        if vid is None:
            self.comms_up = False
            self.intake.close_open(self.t, "broker_down")
        else:
            self.alive = [i for i in self.alive if i != vid]
        return True

    def _process_of(self, name: str) -> Child | None:
        """The child process that runs the process the run calls name (a hosted vehicle: its host)."""
        vid = int(name.split()[1]) if name.startswith("vehicle ") else None
        return self.procs.named(self.hosted.get(vid, name) if vid is not None else name)

    def _unhost(self, vid: int) -> None:
        """Vehicle vid is no longer served by its host; a host left serving none is no longer watched (its end is
        no loss)."""
        host = self.hosted.pop(vid)
        if host not in self.hosted.values():
            self.procs.forget(host)

    def _restart_vehicle(self, vid: int, k: int) -> None:
        seq = self.intake.last_seq.get(vid, 0)
        self.intake.next_tx.pop(vid, None)  # the restarted process may transmit at once (it forgot what it sent)
        self.intake.expect(vid, k)
        self.spawn_vehicle(vid, (self.intake.last_state[vid], seq), k)
        self.await_alive()
        self.alive = sorted([*self.alive, vid])


def _say(what: str | Callable[[], str]) -> str:
    return what if isinstance(what, str) else what()

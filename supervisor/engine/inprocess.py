"""The single-process engine: every vehicle and the channel stepped in one loop.

It runs exactly the pipeline of the multi-process engine (vehicles.step.step_records for each vehicle,
comms.broker.broker_core for the channel, messages built and parsed the same way, the plan of each step from the one
supervisor.plan.schedule.Schedule), in one process
and one thread. Process faults are emulated as the Zenoh engine performs them: a killed vehicle stops stepping (the run
goes on: a scheduled kill is the fault, not a loss) and restarts where it coasted to from its last recorded state
(vehicles.coast); a killed broker loses
what it had in flight and restarts afresh. It is the reference the Zenoh engine must reproduce, and the speed floor
it is measured against.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from comms.broker.broker_core import BrokerCore
from comms.records.bus_records import log_json
from comms.records.events import LinkEvents
from comms.records.messages import (
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    Message,
    rx_key,
    state_key,
    tx_key,
)
from comms.records.network import Network
from comms.records.receptions import RxBatch
from comms.records.records import Kinematics, LinkEvent, Transmission
from comms.records.reports import Counts
from comms.records.run import Graph
from comms.records.state import StateReport
from supervisor.analysis.series import SeriesBuilder
from supervisor.analysis.summary import Series
from supervisor.config.derived import steps_of
from supervisor.config.fleet import broker_core, initial_state, link_stats, radio, restarted_node, vehicle_config
from supervisor.config.scenario_schema import Scenario
from supervisor.engine import interrupts
from supervisor.engine.books import LinkBooks
from supervisor.engine.progress import Progress
from supervisor.errors import SimulationError
from supervisor.plan.faults import ProcessAction
from supervisor.plan.schedule import Schedule, StepPlan
from supervisor.record.meta import RunMeta
from supervisor.record.recorder import LiveSink, Recorder, Sink, Tally
from vehicles.lanes import Job, Outcome, shape_of, step_all
from vehicles.runtime import NodeState

log = logging.getLogger("cpf.engine")


@dataclass(frozen=True, slots=True)
class RunResult:
    series: Series
    wall_time: float  # s, start-up included
    messages: int
    link_counts: dict[str, int]
    link_stats: Message | None  # the supervisor's books of every link at the end (cpf/comms/stats layout)
    stats_history: list[Message]  # {"t", "lambda2"} of the delivered graph per stats window
    estimate_ages: dict[tuple[int, int], list[float]]  # (sender, receiver) -> [sum, count, max] of ages
    stepping_time: float = 0.0  # s of wall time from the first sync step to the end
    realtime: dict[str, Any] | None = None  # realtime runs: how well they kept to the wall clock (realtime_timing)
    malformed: Counts | None = None  # zenoh: reader -> key -> malformed messages it dropped (None: no report)
    scene_messages: int = 0  # the log's Foxglove scene (record.scene), apart from the run's messages
    drop_causes: Counts | None = None  # zenoh: reader -> cause -> messages it dropped


class InProcessRun:
    def __init__(self, scenario: Scenario, rec: Sink, seed: int) -> None:
        self.sc, self.rec, self.seed = scenario, rec, seed
        self.dt = scenario.scenario.step
        self.schedule = Schedule(scenario)
        ids = scenario.vehicle_ids
        self.configs = {i: vehicle_config(scenario, i, seed) for i in ids}
        self.shapes = {i: shape_of(cfg) for i, cfg in self.configs.items()}  # which vehicles step together as lanes
        self.nodes = {i: NodeState(initial_state(scenario, self.configs[i])) for i in ids}
        self.radios = {i: radio(scenario, i) for i in ids}
        self.alive = list(ids)
        self.broker: BrokerCore | None = broker_core(scenario, seed)
        self.books = LinkBooks(link_stats(scenario))
        self.builder = SeriesBuilder(ids, steps_of(scenario), self.dt)
        self.last_state: dict[int, StateReport] = {}  # each vehicle's latest: a restart resumes from it
        self.sent: list[Transmission] = []
        self.where: dict[int, Kinematics] = {}
        self.network: Network | None = None  # in force when `sent` was transmitted
        self.pending: list[LinkEvent] = []  # link events booked, not yet recorded (_flush_events)
        self.stepping: list[int] = []  # the vehicles of the step begun

    def step(self, k: int) -> None:
        plan, jobs = self.begin(k)
        self.take(plan, step_all(jobs))

    def begin(self, k: int) -> tuple[StepPlan, list[Job]]:
        """Step k up to its vehicles' steps: the plan carried out, the channel's deliveries; each vehicle's job."""
        plan = self.schedule.plan(k)
        t = plan.t
        for event in plan.events:
            self.rec.write(FAULT_KEY, t, event.to_message())
        for action in plan.actions:
            self._act(action, k, t)
        if plan.graph_changed:
            self.rec.write(GRAPH_KEY, t, Graph.of(t, plan.network.edges).to_message())
        heard = self._channel(k, t)
        self.books.window(t, self.alive)  # every delivery up to t is booked now
        self.sent, self.where, self.network = [], {}, plan.network
        self.stepping = list(self.alive)  # a vehicle lost on the way leaves self.alive, not this step's list
        return plan, [self._job(i, plan, heard.get(i)) for i in self.stepping]

    def take(self, plan: StepPlan, outcomes: list[Outcome]) -> None:
        """The vehicles' steps of begin's jobs (vehicles.lanes.step_all's outcomes, in order) taken in."""
        for i, outcome in zip(self.stepping, outcomes, strict=True):
            self._vehicle(i, plan.t, outcome)

    def _channel(self, k: int, t: float) -> dict[int, RxBatch]:
        """The broker's work at t: submit last step's transmissions, deliver what is due (nothing if it is down)."""
        if self.broker is None:
            return {}
        self._submit(self.broker, t)
        batches, delivered = self.broker.deliver(t, self.alive)
        self._record_events(delivered)
        self._flush_events(t, k)
        self._record_snapshot(self.broker.snapshot_due(t))
        out = {i: RxBatch.of(i, k, t, batches[i], None) for i in self.alive}
        rec = self.rec
        if isinstance(rec, Tally):
            rec.skip(len(out))
            return out
        for i, batch in out.items():  # in their log form as the Zenoh supervisor writes them (intake): one pass
            rec.write_json(rx_key(i), t, log_json(batch))
        return out

    def _submit(self, broker: BrokerCore, t: float) -> None:
        """Last step's transmissions into the channel. A loss model behind comms.channel.guard that fails stops the run
        as the Zenoh engine's broker process does when it ends with that line (exit 1, the line naming the model)."""
        try:
            events = broker.submit(self.sent, self.where, self.network)
        except FloatingPointError as exc:
            raise SimulationError(f"comms broker stopped at t = {t:.1f} s ({exc})") from None
        self._record_events(events)

    def _job(self, i: int, plan: StepPlan, rx: RxBatch | None) -> Job:
        heard = rx.heard if rx is not None else []  # None: the broker is down
        neighbours, dist = plan.network.neighbours(i), plan.disturbance(i)
        return Job(self.shapes[i], self.configs[i], self.radios[i], self.nodes[i], plan.k, plan.t, self.dt, heard,
                   neighbours, dist)  # fmt: skip

    def _vehicle(self, i: int, t: float, outcome: Outcome) -> None:
        """Vehicle i's step (vehicles.lanes.step_all's outcome) taken in and recorded."""
        if isinstance(outcome, FloatingPointError):  # its closed loop diverged: lost, as the Zenoh engine loses it
            self._lose(i, t, str(outcome))
            return
        if isinstance(outcome, Exception):
            raise outcome
        self.nodes[i], out = outcome
        sent, report = out.transmission, out.report
        if sent is not None:
            self.sent.append(sent)
        rec = self.rec
        if isinstance(rec, Tally):  # a sweep's run: its messages counted, not built
            rec.skip(1 if sent is None else 2)
        else:  # their log form as the Zenoh supervisor writes it (intake), the scene fed the record itself
            if sent is not None:
                rec.write_json(tx_key(i), t, log_json(sent))
            rec.write_state(state_key(i), t, log_json(report), report)
        self.builder.add(report)
        self.last_state[i] = report
        self.where[i] = report.kinematics

    def _act(self, action: ProcessAction, k: int, t: float) -> None:
        """A scheduled kill or restart, as the Zenoh engine carries it out (the schedule is the fault, not a loss:
        the run goes on whatever scenario.on_vehicle_loss says)."""
        vid = action.vehicle
        if action.target == "comms":
            if action.action == "kill" and self.broker is not None:
                self._record_events(self.books.close_open(t, "broker_down"))
                self._flush_events(t, k)
            # Restarted: a fresh broker, nothing of the past in flight or in its statistics.
            self.broker = None if action.action == "kill" else broker_core(self.sc, self.seed)
            self.sent, self.where = [], {}
        elif vid is None or (vid in self.alive) != (action.action == "kill"):
            return  # a dead vehicle is not killed again, a live one not restarted
        elif action.action == "kill":
            self._kill_vehicle(vid)
        else:
            last = self.last_state[vid]
            node = restarted_node(self.configs[vid], last.to_message(), self.nodes[vid].seq, k, self.dt, self.sc.faults)
            self.nodes[vid] = node
            self.alive = sorted([*self.alive, vid])
            action.announce(t, last.t)
            return
        action.announce(t)

    def _lose(self, vid: int, t: float, how: str) -> None:
        """A vehicle that cannot go on (not a scheduled kill): stop the run, or go on without it if the scenario
        says so, as the Zenoh supervisor does when a vehicle process ends."""
        if self.sc.scenario.on_vehicle_loss == "abort":
            raise SimulationError(f"vehicle {vid} stopped at t = {t:.1f} s ({how})")
        log.warning("vehicle %d lost at t = %.1f s (%s); going on without it", vid, t, how)
        self._kill_vehicle(vid)

    def _kill_vehicle(self, vid: int) -> None:
        self.alive = [i for i in self.alive if i != vid]
        self.where.pop(vid, None)
        self.sent = [tx for tx in self.sent if tx.sender != vid]  # it died before its modem could send them

    def finish(self, end: float) -> None:
        k = round(end / self.dt)  # the end's step: its events' batch
        if self.broker is not None:
            self._submit(self.broker, end)
            self._record_events(self.broker.deliver(end, self.alive)[1] + self.broker.finish(end))
            self._flush_events(end, k)
            self._record_snapshot(self.broker.snapshot_due(end, final=True))
        self._record_events(self.books.close_open(end, "end_of_run"))  # if the broker was down at the end
        self._flush_events(end, k)
        self.books.window(end, self.alive)

    def _record_snapshot(self, snapshot: Message | None) -> None:
        """The broker's own statistics, as the broker process publishes them."""
        if snapshot is not None:
            self.rec.write(COMMS_STATS_KEY, float(snapshot["t"]), snapshot)

    def _record_events(self, events: list[LinkEvent]) -> None:
        """Booked now; recorded with the others of their step by _flush_events."""
        self.books.add(events)
        self.pending += events

    def _flush_events(self, t: float, k: int) -> None:
        """The events since the last flush as the broker process publishes them and the Zenoh supervisor records
        them: one cpf/comms/events batch of step k at its time t, each event with its own t (none: no record)."""
        events, self.pending = self.pending, []
        if not events:
            return
        rec = self.rec
        if isinstance(rec, Tally):
            rec.skip(1)
            return
        batch = LinkEvents(t, k, tuple(events))
        rec.write_events(COMMS_EVENTS_KEY, t, log_json(batch), batch.events)


@interrupts.deferring
def run_inprocess(
    scenario: Scenario,
    scenario_file: str,
    scenario_toml: str,
    out: Path | None,
    seed: int,
    progress: Progress,
    scene: bool = True,
    live: LiveSink | None = None,
    speed: float | None = None,
) -> RunResult:
    """Run the scenario, record every message to out (MCAP; None: only counted, for a sweep), and return what the
    summary needs. scene: the log gets the run's Foxglove channels (record.scene); live: sees every record too.
    speed: on the realtime clock, simulated s per wall s (each step waits for its wall time: a run to watch live);
    None: the lockstep clock, as fast as it goes. (supervisor.engine.batch runs many at once, nothing recorded.)"""
    dt = scenario.scenario.step
    steps = steps_of(scenario)
    with Recorder(out, scene, live) if out is not None else Tally() as rec:
        clock = "lockstep" if speed is None else "realtime"
        run = started(scenario, scenario_file, scenario_toml, seed, rec, clock)
        progress.begin()
        began = time.monotonic()
        for k in range(steps):
            if speed is not None:  # step k starts at its wall time, k dt / speed after the first
                time.sleep(max(0.0, began + k * dt / speed - time.monotonic()))
            run.step(k)
            progress.update((k + 1) * dt)
        run.finish(steps * dt)
        stepping = progress.stepping_time()
        wall = progress.done(steps * dt)
    return result(run, rec, steps * dt, wall, stepping)


def started(
    scenario: Scenario, scenario_file: str, scenario_toml: str, seed: int, rec: Sink, clock: str
) -> InProcessRun:
    """A run at its start, its metadata and graph recorded."""
    rec.limit(scenario.scenario.duration)
    meta = RunMeta.of(scenario, scenario_file, scenario_toml, seed, "inprocess", clock)
    rec.write(META_KEY, 0.0, meta.to_message())
    rec.write(GRAPH_KEY, 0.0, Graph.of(0.0, scenario.graph.edges).to_message())
    return InProcessRun(scenario, rec, seed)


def result(run: InProcessRun, rec: Sink, end: float, wall: float, stepping: float) -> RunResult:
    """What a finished run gives, once its recorder is closed (its log's scene is written then)."""
    books = run.books
    return RunResult(
        run.builder.series(), wall, rec.count, books.counts, books.stats.snapshot(end), books.lambda2,
        run.builder.ages, stepping, scene_messages=rec.scene_count,
    )  # fmt: skip

"""The Zenoh supervisor's clock: it issues tick k with what the step plan (supervisor.plan.schedule) puts in force
over step k, after publishing the faults that start or end with it and carrying out the kills and restarts due.

The plan is asked, never recomputed here: the in-process engine and re-simulation ask the same Schedule, so the
three engines cannot drift. In lockstep a tick grants a time window of steps inside which nothing can cross the bus
(supervisor.engine.windows: up to the next step at which a vehicle may transmit or anything external changes); the
log keeps one tick record per step of it, as stepping one step at a time writes them. A tick may go out a window
ahead (the broker then starts the next window the moment the states of this one arrive) unless the vehicles' fresh
reports could lengthen it; a tick with a kill or restart due, and every realtime tick (a window of one step), waits
for the step before.
"""

from __future__ import annotations

import time
from typing import Protocol

from comms.bus.bus import Publishers
from comms.records.messages import (
    COMMS_STEP_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    TICK_KEY,
    Message,
    batches_message,
    tick_lead,
    tick_message,
)
from comms.records.network import Network
from comms.records.run import Graph
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.windows import Reports, window_end, worth_waiting
from supervisor.plan.faults import ProcessAction
from supervisor.plan.schedule import Schedule, StepPlan

# Lockstep windows end after this many steps even when nothing could cross the bus for longer: the supervisor hears
# from the fleet (progress, a stuck run's timeout per step) at least this often, and a round trip per 100 steps
# costs next to nothing.
LONGEST_WINDOW = 100


class Driven(Protocol):
    """What the clock needs of the supervisor it drives."""

    alive: list[int]
    comms_up: bool

    @property
    def reports(self) -> Reports: ...

    def record(self, key: str, t: float, message: Message) -> None: ...

    def pump(self, timeout: float) -> None: ...

    def publish(self, key: str, t: float, message: Message) -> None: ...

    def carry_out(self, action: ProcessAction, k: int) -> None: ...

    def grant(self, reach: int) -> None:
        """The steps before reach are granted on the bus: a vehicle's state of a later step does not fit the run."""


class Clock:
    """Issues the ticks of one run: lockstep (as fast as the states come) or realtime (paced to the wall clock)."""

    def __init__(self, sc: Scenario, pubs: Publishers, mode: str, speed: float, longest: int | None = None) -> None:
        """longest: lockstep windows of at most this many steps (1: step by step; None: LONGEST_WINDOW)."""
        self.schedule = Schedule(sc)  # the run's one plan
        self.pubs, self.mode, self.speed = pubs, mode, speed
        self.longest = 1 if mode == "realtime" else longest or LONGEST_WINDOW  # realtime paces a tick per step
        self.fleet = len(sc.vehicle_ids)
        self.usual = Network.of((a, b) for a, b in sc.graph.edges)  # the scenario's graph, no link faults
        self.lead = tick_lead(sc.scenario.step, speed)
        self.wall_start, self.epoch_start = time.monotonic(), time.time()  # pacing; the wall clock processes share
        self.begun = False
        self.issued: Message | None = None
        self.issued_end = 0  # the first step after the latest tick's window
        self.ahead = False  # the latest tick went out before every state of the step before it was in
        self.spans: list[tuple[int, int, Message]] = []  # lockstep spans granted: (first step, reach, the grant)
        self.waiting = 0  # the step whose states the supervisor waits for
        self._plans: dict[int, StepPlan] = {}  # the steps asked for lately: each is asked at k-1 (hold), ahead, at k

    def begin(self) -> None:
        """Stepping starts now: realtime ticks are paced from here."""
        self.wall_start, self.epoch_start, self.begun = time.monotonic(), time.time(), True

    def plan(self, k: int) -> StepPlan:
        if k not in self._plans:
            self._plans = {j: p for j, p in self._plans.items() if j >= k - 1}
            self._plans[k] = self.schedule.plan(k)
        return self._plans[k]

    def can_run_ahead(self, run: Driven, k: int) -> bool:
        """Tick k may go out before the states of step k-1 are in: lockstep, no kill or restart due at k, and the
        window it would grant could not be longer once they are in."""
        if self.mode != "lockstep" or self.plan(k).actions:
            return False
        if k >= self.schedule.steps or self._spanning(run, k) or self.longest == 1:
            return True
        return not worth_waiting(k, *self._window_facts(run, k))

    def _window_facts(self, run: Driven, k: int) -> tuple[int, list[int], Reports]:
        return self.schedule.next_change(k), run.alive, run.reports

    def issue(self, run: Driven, k: int, ahead: bool = False) -> int:
        """Tick k, after the faults starting or ending with it and the kills and restarts due (none at the end);
        returns the first step after the window it grants."""
        plan, self.ahead = self.plan(k), ahead
        if self.mode == "realtime":
            _pace(run, self.wall_start + plan.t / self.speed - self.lead)
        if not plan.final:
            for event in plan.events:
                run.publish(FAULT_KEY, plan.t, event.to_message())
            for action in plan.actions:
                run.carry_out(action, k)
            if plan.graph_changed:
                run.publish(GRAPH_KEY, plan.t, Graph.of(plan.t, plan.network.edges).to_message())
        if self._spanning(run, k):
            return self._grant(run, plan)
        end = k + 1 if plan.final else window_end(k, *self._window_facts(run, k), self.longest)
        self._publish(run, plan, end)
        return end

    def _spanning(self, run: Driven, k: int) -> bool:
        """Whether step k starts a span the broker runs itself (comms.broker.span): lockstep with windows, a broker
        up."""
        return self.mode == "lockstep" and self.longest > 1 and run.comms_up and k < self.schedule.steps

    def _grant(self, run: Driven, plan: StepPlan) -> int:
        """The broker is granted steps plan.k up to the next change (comms.broker.span); returns that step. Their ticks
        go on the record one by one as the supervisor reaches them (record)."""
        reach = self.schedule.next_change(plan.k)
        self.spans = [span for span in self.spans if span[1] > self.waiting] + [(plan.k, reach, {})]
        self.issued = None  # nothing of the supervisor's own ticks to say again: the grant says it (reissue)
        self._publish_grant(run, plan, reach)
        return reach

    def _publish_grant(self, run: Driven, plan: StepPlan, reach: int, start: int | None = None) -> None:
        """The grant of steps start (default plan.k) .. reach-1 on the bus; the template of their ticks kept."""
        k = plan.k if start is None else start
        disturbed = {i: plan.disturbances[i] for i in run.alive if i in plan.disturbances}
        spelt = None if plan.network == self.usual else plan.network
        alive = None if len(run.alive) == self.fleet else list(run.alive)
        hold = bool(self.plan(reach).actions) if reach < self.schedule.steps else False
        template = tick_message(k, k * self.schedule.dt, False, disturbed, spelt, alive, run.comms_up, None,
                                self.speed, hold, None, reach, self.longest)  # fmt: skip
        self.spans = [(a, b, m) if (a, b) != (plan.k, reach) else (a, b, template) for a, b, m in self.spans]
        run.grant(reach)
        self.pubs.put(TICK_KEY, template)

    def record(self, run: Driven, k: int) -> None:
        """The supervisor reaches step k: its tick on the record if a span the broker runs holds it (a tick the
        supervisor published itself is on it already)."""
        self.waiting = k
        for _, reach, grant in self.spans:
            if int(grant["k"]) <= k < reach:
                t = float(grant["t"]) if int(grant["k"]) == k else k * self.schedule.dt
                tick = {**grant, "k": k, "t": t, "hold": bool(grant["hold"]) and k == reach - 1}
                del tick["span"], tick["longest"]  # the log keeps one tick per step, as stepping writes them
                run.record(TICK_KEY, t, tick)
                return

    def ahead_at(self, a: int, b: int) -> int:
        """At which step of the stretch a .. b-1 just issued the next tick may go out ahead: at once after a window
        (the broker starts the next the moment this one's states arrive), near the end of a span (its grant
        carries the faults that start with it: said on the bus no earlier than needed)."""
        return b - 1 if any(first == a and reach == b for first, reach, _ in self.spans) else a

    def reissue(self, run: Driven) -> None:
        """A vehicle was lost after the latest tick went out ahead counting it alive: say it again without it, or
        the broker would wait for that vehicle's state forever."""
        if self.issued is not None and self.ahead:
            self._publish(run, self.plan(int(self.issued["k"])), self.issued_end)
        for first, reach, _ in list(self.spans):  # the spans granted with it, from the next step on
            start = max(first, self.waiting + 1)
            if start < reach:
                self._publish_grant(run, self.plan(first), reach, start)

    def _publish(self, run: Driven, plan: StepPlan, end: int) -> None:
        """The tick of the window plan.k .. end-1 on the bus; in the log, one tick per step (as one step at a time)."""
        disturbed = {i: plan.disturbances[i] for i in run.alive if i in plan.disturbances}
        wall = self.epoch_start + plan.t / self.speed if self.mode == "realtime" else None
        # The common case in its short form (null: the scenario's graph without link faults, every vehicle alive):
        # every process parses every tick, and with a large fleet the long form costs more than the step itself.
        spelt = None if plan.network == self.usual else plan.network
        alive = None if len(run.alive) == self.fleet else list(run.alive)  # alive: a subset of the ids
        hold = not plan.final and bool(self.plan(end).actions)
        final, comms, until = plan.final, run.comms_up, end if end > plan.k + 1 else None
        self.issued = tick_message(plan.k, plan.t, final, disturbed, spelt, alive, comms, wall, self.speed, hold, until)
        self.issued_end = end
        run.grant(end)
        if until is None:
            run.publish(TICK_KEY, plan.t, self.issued)
        else:
            self.pubs.put(TICK_KEY, self.issued)
            for j in range(plan.k, end):  # nothing changes inside the window: only k, t and the last one's hold
                t = plan.t if j == plan.k else j * self.schedule.dt
                held = hold and j == end - 1
                step = tick_message(j, t, False, disturbed, spelt, alive, comms, wall, self.speed, held)
                run.record(TICK_KEY, t, step)
        if not comms and not final:  # no broker to hand the vehicles their tick: no receptions either
            self.pubs.put(COMMS_STEP_KEY, batches_message(self.issued, None))


def _pace(run: Driven, target: float) -> None:
    """Realtime clock: keep recording until the wall clock reaches the tick's time."""
    while (left := target - time.monotonic()) > 0:
        run.pump(min(left, 0.05))

"""The Zenoh supervisor's clock: it issues tick k with what the step plan (supervisor.plan.schedule) puts in force
over step k, after publishing the faults that start or end with it and carrying out the kills and restarts due.

The plan is asked, never recomputed here: the in-process engine and re-simulation ask the same Schedule, so the
three engines cannot drift. In lockstep a tick may go out a step ahead (the broker then starts step k+1 the moment
the states of step k arrive); a tick with a kill or restart due, and every realtime tick, waits for the step before.
"""

from __future__ import annotations

import time
from typing import Protocol

from comms.bus import Publishers
from comms.messages import (
    COMMS_STEP_KEY,
    FAULT_KEY,
    GRAPH_KEY,
    TICK_KEY,
    Message,
    batches_message,
    tick_lead,
    tick_message,
)
from comms.network import Network
from comms.run import Graph
from supervisor.config.scenario_schema import Scenario
from supervisor.plan.faults import ProcessAction
from supervisor.plan.schedule import Schedule, StepPlan


class Driven(Protocol):
    """What the clock needs of the supervisor it drives."""

    alive: list[int]
    comms_up: bool

    def pump(self, timeout: float) -> None: ...

    def publish(self, key: str, t: float, message: Message) -> None: ...

    def carry_out(self, action: ProcessAction, k: int) -> None: ...


class Clock:
    """Issues the ticks of one run: lockstep (as fast as the states come) or realtime (paced to the wall clock)."""

    def __init__(self, sc: Scenario, pubs: Publishers, mode: str, speed: float) -> None:
        self.schedule = Schedule(sc)  # the run's one plan
        self.pubs, self.mode, self.speed = pubs, mode, speed
        self.fleet = len(sc.vehicle_ids)
        self.usual = Network(tuple((a, b) for a, b in sc.graph.edges))  # the scenario's graph, no link faults
        self.lead = tick_lead(sc.scenario.step, speed)
        self.wall_start, self.epoch_start = time.monotonic(), time.time()  # pacing; the wall clock processes share
        self.begun = False
        self.issued: Message | None = None
        self.ahead = False  # the latest tick went out before every state of the step before it was in
        self._plans: dict[int, StepPlan] = {}  # the steps asked for lately: each is asked at k-1 (hold), ahead, at k

    def begin(self) -> None:
        """Stepping starts now: realtime ticks are paced from here."""
        self.wall_start, self.epoch_start, self.begun = time.monotonic(), time.time(), True

    def plan(self, k: int) -> StepPlan:
        if k not in self._plans:
            self._plans = {j: p for j, p in self._plans.items() if j >= k - 1}
            self._plans[k] = self.schedule.plan(k)
        return self._plans[k]

    def can_run_ahead(self, k: int) -> bool:
        """Tick k may go out before the states of step k-1 are in: lockstep, and no kill or restart due at k."""
        return self.mode == "lockstep" and not self.plan(k).actions

    def issue(self, run: Driven, k: int, ahead: bool = False) -> None:
        """Tick k, after the faults starting or ending with it and the kills and restarts due (none at the end)."""
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
        self._publish(run, plan)

    def reissue(self, run: Driven) -> None:
        """A vehicle was lost after the latest tick went out ahead counting it alive: say it again without it, or
        the broker would wait for that vehicle's state forever."""
        if self.issued is not None and self.ahead:
            self._publish(run, self.plan(int(self.issued["k"])))

    def _publish(self, run: Driven, plan: StepPlan) -> None:
        disturbed = {i: plan.disturbances[i] for i in run.alive if i in plan.disturbances}
        wall = self.epoch_start + plan.t / self.speed if self.mode == "realtime" else None
        # The common case in its short form (null: the scenario's graph without link faults, every vehicle alive):
        # every process parses every tick, and with a large fleet the long form costs more than the step itself.
        spelt = None if plan.network == self.usual else plan.network
        alive = None if len(run.alive) == self.fleet else list(run.alive)  # alive: a subset of the ids
        hold = not plan.final and bool(self.plan(plan.k + 1).actions)
        final, comms = plan.final, run.comms_up
        self.issued = tick_message(plan.k, plan.t, final, disturbed, spelt, alive, comms, wall, self.speed, hold)
        run.publish(TICK_KEY, plan.t, self.issued)
        if not comms and not final:  # no broker to hand the vehicles their tick: no receptions either
            self.pubs.put(COMMS_STEP_KEY, batches_message(self.issued, None))


def _pace(run: Driven, target: float) -> None:
    """Realtime clock: keep recording until the wall clock reaches the tick's time."""
    while (left := target - time.monotonic()) > 0:
        run.pump(min(left, 0.05))

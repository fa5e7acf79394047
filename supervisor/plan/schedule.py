"""The plan of a run: what is in force over each sync step, computed once from the scenario.

Every engine (in-process, the Zenoh supervisor's clock, re-simulation) asks the same `Schedule` what step k brings:
the faults that start or end with it, the kills and restarts due, the network, each vehicle's disturbances, and
whether the graph changed. Nothing here depends on how the step is carried out, so a new fault kind changes the plan
once and every engine follows.

The schedule knows the steps at which anything external changes (`change_steps`), so "until which step does nothing
external change?" is one call (`next_change`): a window of steps inside which the plan is the same but for k and t.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from types import MappingProxyType

from comms.records.network import Network
from comms.records.records import Disturbances
from supervisor.config.derived import active, end_of, first_step, steps_of
from supervisor.config.scenario_schema import FaultSpec, Scenario, VehicleKillFault
from supervisor.plan.faults import (
    FaultEvent,
    ProcessAction,
    _disturbances,
    _events_at,
    _network_at,
    _process_actions,
)

_NO_DISTURBANCES: MappingProxyType[int, Disturbances] = MappingProxyType({})
_UNDISTURBED = Disturbances()  # frozen: one for every vehicle no fault acts on (a fleet of 1000 made 1000 a step)


@dataclass(frozen=True, slots=True)
class StepPlan:
    """What is in force over the step [t, t + dt) with t = k dt."""

    k: int
    t: float
    final: bool  # k == steps: the end of the run, nothing is stepped
    events: tuple[FaultEvent, ...]  # faults starting or ending with this step
    actions: tuple[ProcessAction, ...]  # kills and restarts due now (kills first)
    network: Network
    disturbances: MappingProxyType[int, Disturbances]  # vehicles some fault acts on; the others: Disturbances()
    graph_changed: bool  # the graph differs from the previous step's (at k = 0: from the scenario's graph)

    def disturbance(self, vehicle: int) -> Disturbances:
        return self.disturbances.get(vehicle, _UNDISTURBED)


class Schedule:
    """The scenario's fault schedule on the step grid: plans by step, and the steps where something changes."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.dt = scenario.scenario.step
        self.steps = steps_of(scenario)
        changes = {0, self.steps}
        for fault in scenario.faults:
            for edge in (fault.start, _end_or_none(fault, self.dt)):
                if edge is not None:
                    k = first_step(edge, self.dt)
                    if k <= self.steps:
                        changes.add(k)
        self._changes = sorted(changes)
        self._is_change = frozenset(changes)
        self._initial_edges = tuple((int(i), int(j)) for i, j in scenario.graph.edges)  # as a Network holds them
        self._segments: dict[int, tuple[Network, MappingProxyType[int, Disturbances]]] = {}

    @property
    def change_steps(self) -> list[int]:
        """Steps at which a fault starts or ends or a process action is due, with 0 and the last step."""
        return list(self._changes)

    def next_change(self, k: int) -> int:
        """The first step after k at which anything external changes (at most `steps`): steps k .. next_change(k)-1
        share one network and one set of disturbances, and only k = their first may bring events or actions."""
        return self._changes[bisect.bisect_right(self._changes, k)] if k < self.steps else self.steps

    def plan(self, k: int) -> StepPlan:
        """The plan of step k (0 <= k <= steps; k == steps is the end of the run)."""
        if not 0 <= k <= self.steps:
            raise ValueError(f"step {k} is outside the run (0..{self.steps})")
        t, dt, faults = k * self.dt, self.dt, self.scenario.faults
        at_change = k in self._is_change
        events = tuple(_events_at(faults, t, dt)) if at_change else ()
        actions = tuple(_process_actions(faults, t, dt)) if at_change else ()
        network, dist = self._in_force(k, t)
        before = self._in_force(k - 1, t - dt)[0].edges if k > 0 else self._initial_edges
        changed = at_change and network.edges != before
        return StepPlan(k, t, k == self.steps, events, actions, network, dist, changed)

    def _in_force(self, k: int, t: float) -> tuple[Network, MappingProxyType[int, Disturbances]]:
        """Network and disturbances of step k, computed once per stretch between changes."""
        start = self._changes[bisect.bisect_right(self._changes, k) - 1]
        if start not in self._segments:
            sc = self.scenario
            dist = {i: d for i in sc.vehicle_ids if (d := _disturbances(sc.faults, i, t, self.dt)) != Disturbances()}
            self._segments[start] = (_network_at(sc, t, self.dt), MappingProxyType(dist) if dist else _NO_DISTURBANCES)
        return self._segments[start]

    def scheduled_alive(self, k: int) -> list[int]:
        """Vehicles no scheduled kill holds down over step k (unscheduled losses are the engine's to subtract)."""
        t = k * self.dt
        down = {f.vehicle for f in self.scenario.faults if isinstance(f, VehicleKillFault) and active(f, t, self.dt)}
        return [i for i in self.scenario.vehicle_ids if i not in down]


def _end_or_none(fault: FaultSpec, dt: float) -> float | None:
    end = end_of(fault, dt)
    return None if math.isinf(end) else end

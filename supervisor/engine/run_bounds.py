"""What a message the supervisor takes in must fit: the run's fleet, the links any of its graphs has, its steps and
their times (supervisor.engine.intake checks every message against them)."""

from __future__ import annotations

from dataclasses import dataclass

from comms.records.stream import at_step_time
from supervisor.config.derived import steps_of
from supervisor.config.scenario_schema import GraphSwitchFault, Scenario
from supervisor.record.recorder import TIME_MARGIN


@dataclass(frozen=True, slots=True)
class RunBounds:
    """What a message must fit: the fleet, the links any graph of the run has, the steps and their times."""

    vehicles: frozenset[int]
    links: frozenset[tuple[int, int]]
    steps: int
    dt: float
    end: float  # s: the latest time a message may carry (the run's end, and the recorder's margin)

    @classmethod
    def of(cls, sc: Scenario) -> RunBounds:
        graphs = [sc.graph.edges, *(f.edges for f in sc.faults if isinstance(f, GraphSwitchFault))]
        links = {(int(i), int(j)) for edges in graphs for i, j in edges}
        steps = steps_of(sc)
        both = links | {(j, i) for i, j in links}
        return cls(frozenset(sc.vehicle_ids), frozenset(both), steps, sc.scenario.step, steps * sc.scenario.step)

    def time(self, t: float, what: str) -> None:
        if not 0.0 <= t <= self.end + TIME_MARGIN:
            raise ValueError(f"{what} t = {t:g} s is outside the run (0 to {self.end:g} s)")

    def step(self, k: int, t: float) -> None:
        """A vehicle's step k, at t = k dt (up to rounding): the supervisor's ticks say so."""
        if not 0 <= k < self.steps:
            raise ValueError(f"step {k} is outside the run (0 to {self.steps - 1})")
        at_step_time(t, k, self.dt, "the state's")

    def vehicle(self, vid: int) -> None:
        if vid not in self.vehicles:
            raise ValueError(f"no vehicle {vid} in the run")

    def link(self, sender: int, receiver: int) -> None:
        if (sender, receiver) not in self.links:
            raise ValueError(f"no link {sender}->{receiver} in any graph of the run")

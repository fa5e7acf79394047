"""Numbers that follow from a scenario, each computed in one place: the number of steps, when a fault acts on the
step grid, the graph in force, the tube radius, the unit of gamma.

Faults take effect at sync-step boundaries: a fault on [start, end) acts during every step [t, t + dt) with
start <= t < end, to within half a step, so that times given in a scenario land on the step grid robustly.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from supervisor.config.scenario_schema import BrokerKillFault, FaultSpec, FrozenGammaFault, GraphSwitchFault, Scenario

STEP_TOLERANCE = 1e-6  # relative: how close to a whole number of steps a duration, slot or period must be


def whole_steps(seconds: float, dt: float) -> bool:
    """Whether seconds is a whole number of steps of dt. The vehicles decide on the step grid: a period of 1.5 steps
    fell on 1 or 2 steps by the rounding of each time stamp (0.15 s at a 0.1 s step sent 421 messages in 60 s)."""
    steps = seconds / dt
    return abs(steps - round(steps)) <= STEP_TOLERANCE * max(1.0, steps)


def steps_of(scenario: Scenario) -> int:
    """The run's sync steps: duration / step (the checks hold the step to dividing the duration)."""
    return round(scenario.scenario.duration / scenario.scenario.step)


def tube_radius(scenario: Scenario) -> float:
    """Where path-following must keep each vehicle after the transient: |delta| plus the report's margin, m."""
    return abs(scenario.path_following.delta) + scenario.report.tube_margin


def end_of(fault: FaultSpec, dt: float) -> float:
    """When a fault stops acting; a broker restarts one step after being killed unless told otherwise."""
    if fault.end is not None:
        return fault.end
    return fault.start + dt if isinstance(fault, BrokerKillFault) else math.inf


def active(fault: FaultSpec, t: float, dt: float) -> bool:
    """Whether the fault acts over the step starting at t."""
    eps = dt / 2
    return fault.start - eps <= t < end_of(fault, dt) - eps


def first_step(t: float, dt: float) -> int:
    """The first sync step k whose start k dt a fault starting (or ending) at t acts from (half a step early)."""
    k = max(0, round(t / dt))
    while k > 0 and (k - 1) * dt >= t - dt / 2:
        k -= 1
    while k * dt < t - dt / 2:
        k += 1
    return k


def steps_of_fault(fault: FaultSpec, dt: float) -> tuple[int, int | None]:
    """The sync steps a fault acts on, first .. end - 1 (end None: to the end of the run), as active() has them."""
    end = end_of(fault, dt)
    return first_step(fault.start, dt), None if math.isinf(end) else first_step(end, dt)


def stuck_spans(faults: Iterable[FaultSpec], vehicle: int, dt: float) -> list[tuple[int, int | None]]:
    """The steps over which the vehicle's gamma sensor is stuck without a break, (first, end) as steps_of_fault:
    its frozen_gamma faults, those that overlap or meet as one (the reading stays the one of the first step)."""
    mine = [steps_of_fault(f, dt) for f in faults if isinstance(f, FrozenGammaFault) and f.vehicle == vehicle]
    spans = sorted(mine, key=lambda span: (span[0], math.inf if span[1] is None else span[1]))  # None: no end
    merged: list[tuple[int, int | None]] = []
    for first, end in spans:
        last = merged[-1] if merged else None
        if last is not None and (last[1] is None or first <= last[1]):
            merged[-1] = (last[0], None if last[1] is None or end is None else max(last[1], end))
        else:
            merged.append((first, end))
    return merged


def intervals(scenario: Scenario) -> list[tuple[str, float, float]]:
    """(kind, start, end) of every fault, open ends closed at the end of the run: for summaries and plots. Times
    on the step grid, the steps the fault acts on (steps_of_fault: what the run and the faults table do), as the
    series' own times k dt: a fault given at 5.03 s acts from the step at 5.0 s, and its phase starts there."""
    duration, dt = scenario.scenario.duration, scenario.scenario.step
    out: list[tuple[str, float, float]] = []
    for f in scenario.faults:
        first, end = steps_of_fault(f, dt)
        out.append((f.kind, _grid_time(first, dt), duration if end is None else min(_grid_time(end, dt), duration)))
    return out


def _grid_time(k: int, dt: float) -> float:
    """k dt as a person writes it (3 x 0.1 s: 0.3, not 0.30000000000000004, in metrics.json): rounded to 1 ns, far
    below half a step; the summary takes each step's side with half a step's slack (k dt may fall either side of
    it: 3 x 0.3 = 0.8999999999999999)."""
    return round(k * dt, 9)


def graph_at(scenario: Scenario, t: float, dt: float) -> tuple[tuple[int, int], ...]:
    """The communication graph over the step starting at t: the latest graph switch in force, or the scenario's."""
    switches = [f for f in scenario.faults if isinstance(f, GraphSwitchFault) and active(f, t, dt)]
    edges = max(switches, key=lambda f: f.start).edges if switches else scenario.graph.edges
    return tuple((int(i), int(j)) for i, j in edges)


def gamma_unit(paths: Iterable[Mapping[str, Any]]) -> str | None:
    """The unit of gamma the paths (their specs, as the scenario file gives them) share: "" where gamma is a number
    (a helix or circle: revolutions in units of 1/period), "m" where it is metres of path (a line of unit velocity, a
    lawnmower of scale 1), "k m" for k metres; None if they do not share one (a mixed fleet, or none given)."""
    units = {_unit(path) for path in paths}
    return units.pop() if len(units) == 1 else None


def _unit(path: Mapping[str, Any]) -> str:
    if path.get("type") == "line":
        metres = math.sqrt(sum(float(c) ** 2 for c in path.get("velocity", (1.0, 0.0, 0.0))))
    elif path.get("type") == "lawnmower":
        metres = float(path.get("scale", 1.0))
    else:
        return ""
    return "m" if metres == 1.0 else f"{metres:g} m"


def rate_label(unit: str | None) -> str:
    """The unit of gamma_dot for an axis: 1/s, m/s, (2 m)/s, or the unit of gamma per s when the paths differ."""
    if unit is None:
        return "unit of gamma per s"
    return "1/s" if unit == "" else f"{unit}/s" if unit == "m" else f"({unit})/s"

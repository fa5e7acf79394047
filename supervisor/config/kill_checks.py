"""Scheduled kills of a process (vehicle_kill, broker_kill) that the engines cannot carry out as written: two of one
process that overlap or meet, and a vehicle's restart with no state to resume from.

A kill stops a process and its end restarts it (supervisor.plan.faults): a second kill of a process already down does
nothing, and the first kill's end restarts it while the second should still hold it down (in process the broker came
back early and delivered; over Zenoh the supervisor tried to kill a broker it no longer had and the run timed out).
Kills that meet (one ends at the step the next starts) restart and kill at one step, which neither engine orders so.
A restarted vehicle resumes from its last state (vehicles.coast): one killed from the first step has none.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from supervisor.config.derived import end_of, first_step
from supervisor.config.scenario_schema import BrokerKillFault, FaultSpec, Scenario, VehicleKillFault


def kill_errors(sc: Scenario) -> Iterator[str]:
    dt = sc.scenario.step
    kills = [(n, f) for n, f in enumerate(sc.faults) if isinstance(f, (VehicleKillFault, BrokerKillFault))]
    for n, fault in kills:
        if isinstance(fault, VehicleKillFault) and fault.end is not None and first_step(fault.start, dt) == 0:
            yield (
                f"faults[{n}].end: a vehicle_kill from the first step cannot end: the restarted vehicle resumes "
                f"from its last state and has none (start it at {dt:g} s or later, or leave out end), got {fault.end}"
            )
    for (i, first), (j, second) in ((a, b) for a in kills for b in kills if a[0] < b[0]):
        if _process(first) == _process(second) and _meet(first, second, dt):
            yield (
                f"faults[{j}]: a {second.kind} of {_process(second)} that overlaps or meets faults[{i}] "
                f"({_steps(first, dt)} s): a process is killed once at a time (make them one fault), "
                f"got {_steps(second, dt)} s"
            )


def _process(fault: FaultSpec) -> str:
    return f"vehicle {fault.vehicle}" if isinstance(fault, VehicleKillFault) else "the comms broker"


def _span(fault: FaultSpec, dt: float) -> tuple[int, float]:
    """The steps it holds the process down: [first, last), last inf without end."""
    end = end_of(fault, dt)
    return first_step(fault.start, dt), (first_step(end, dt) if math.isfinite(end) else math.inf)


def _meet(a: FaultSpec, b: FaultSpec, dt: float) -> bool:
    (a0, a1), (b0, b1) = _span(a, dt), _span(b, dt)
    return a0 <= b1 and b0 <= a1


def _steps(fault: FaultSpec, dt: float) -> str:
    end = end_of(fault, dt)
    return f"[{fault.start:g}, {end:g})" if math.isfinite(end) else f"from {fault.start:g}"

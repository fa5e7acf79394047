"""The fault schedule: which faults are active at a time, and the start/end events to record.

Faults take effect at sync-step boundaries: a fault with start s is active during every step [t, t + dt) with
t >= s (to within half a step, so that times given in the scenario land on the step grid robustly).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from supervisor.scenario_schema import FaultSpec, SpeedCapFault
from vehicles.agent import Disturbances


@dataclass(frozen=True, slots=True)
class FaultEvent:
    t: float
    kind: str
    phase: str  # "start" | "end"
    detail: dict[str, object]

    def message(self) -> dict[str, object]:
        return {"t": self.t, "kind": self.kind, "phase": self.phase, "detail": self.detail}


def active(fault: FaultSpec, t: float, dt: float) -> bool:
    eps = dt / 2
    return fault.start - eps <= t < fault.end - eps


def disturbances(faults: Sequence[FaultSpec], vehicle_id: int, t: float, dt: float) -> Disturbances:
    """What the active faults do to one vehicle over the step starting at t."""
    caps = [
        f.gamma_dot_max for f in faults if isinstance(f, SpeedCapFault) and f.vehicle == vehicle_id and active(f, t, dt)
    ]
    return Disturbances(gamma_dot_cap=min(caps) if caps else None)


def events_at(faults: Sequence[FaultSpec], t: float, dt: float) -> list[FaultEvent]:
    """Faults that start or end with the step starting at t."""
    events = []
    for fault in faults:
        now, before = active(fault, t, dt), active(fault, t - dt, dt) if t > 0 else False
        if now != before:
            detail = fault.model_dump(exclude={"kind"})
            events.append(FaultEvent(t, fault.kind, "start" if now else "end", detail))
    return events

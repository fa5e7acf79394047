"""The fault schedule: what acts on each vehicle, on the network and on the processes over each sync step.

Faults take effect at sync-step boundaries: a fault on [start, end) is active during every step [t, t + dt) with
start <= t < end (to within half a step, so that times given in a scenario land on the step grid robustly).
The per-step functions here are private to the plan package: supervisor.plan.schedule.Schedule is their one caller,
and every engine asks the Schedule, so a new fault kind's effect is written here once and reaches them all.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

from comms.records.network import Network
from comms.records.records import Disturbances
from comms.records.run import FaultEvent  # a fault starting or ending: the plan's record, as the log keeps it
from supervisor.config.derived import active, graph_at, steps_of_fault
from supervisor.config.scenario_schema import (
    BlackoutFault,
    ClockSkewFault,
    FaultSpec,
    FrozenGammaFault,
    GammaOffsetFault,
    LinkDegradedFault,
    LinkDownFault,
    ModemSilentFault,
    Scenario,
    SpeedCapFault,
    VehicleKillFault,
)

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)


def _disturbances(faults: Sequence[FaultSpec], vehicle_id: int, t: float, dt: float) -> Disturbances:
    """What the active faults do to one vehicle over the step starting at t."""
    mine = [f for f in faults if getattr(f, "vehicle", None) == vehicle_id and active(f, t, dt)]
    caps = [f.gamma_dot_max for f in mine if isinstance(f, SpeedCapFault)]
    return Disturbances(
        gamma_dot_cap=min(caps) if caps else None,
        gamma_freeze=any(isinstance(f, FrozenGammaFault) for f in mine),
        gamma_offset=sum(f.offset for f in mine if isinstance(f, GammaOffsetFault)),
        clock_offset=sum(f.offset for f in mine if isinstance(f, ClockSkewFault)),
    )


def _network_at(scenario: Scenario, t: float, dt: float) -> Network:
    """The network over the step starting at t: the latest graph switch in force, and the link faults."""
    on = [f for f in scenario.faults if active(f, t, dt)]
    edges = graph_at(scenario, t, dt)
    down: set[tuple[int, int]] = set()
    degraded: dict[tuple[int, int], tuple[float, float]] = {}
    for f in on:
        links = (
            [(f.sender, f.receiver), (f.receiver, f.sender)] if isinstance(f, LinkDownFault | LinkDegradedFault) else []
        )
        for link in links[: 2 if getattr(f, "both", False) else 1]:
            if isinstance(f, LinkDownFault):
                down.add(link)
            elif isinstance(f, LinkDegradedFault):
                loss, delay = degraded.get(link, (0.0, 0.0))
                degraded[link] = (1 - (1 - loss) * (1 - f.extra_loss), delay + f.extra_delay)
    return Network.of(
        edges,
        down,
        degraded,
        any(isinstance(f, BlackoutFault) for f in on),
        frozenset(f.vehicle for f in on if isinstance(f, ModemSilentFault)),
    )


def _events_at(faults: Sequence[FaultSpec], t: float, dt: float) -> list[FaultEvent]:
    """Faults that start or end with the step starting at t."""
    events = []
    for fault in faults:
        now, before = active(fault, t, dt), active(fault, t - dt, dt) if t > 0 else False
        if now != before:
            detail = fault.model_dump(exclude={"kind"})
            events.append(FaultEvent(t, fault.kind, "start" if now else "end", detail))
    return events


@dataclass(frozen=True, slots=True)
class ProcessAction:
    """A scheduled kill or restart. A scheduled kill is the fault itself, not a loss: the run goes on without the
    process (whatever scenario.on_vehicle_loss says, which is about unscheduled deaths) until its restart, if any."""

    action: str  # "kill" | "restart"
    target: str  # "comms" | "vehicle"
    vehicle: int | None = None
    until: float | None = None  # a kill: when the process is restarted (None: never)

    @property
    def name(self) -> str:
        return "comms broker" if self.target == "comms" else f"vehicle {self.vehicle}"

    @property
    def kind(self) -> str:
        return "broker_kill" if self.target == "comms" else "vehicle_kill"

    def announce(self, t: float, resumed_from: float | None = None) -> None:
        """Say what the schedule does now (the log records it as the fault's start or end on cpf/run/fault)."""
        if self.action == "kill":
            then = "the run goes on without it" if self.until is None else f"restarted at t = {self.until:.1f} s"
            log.warning("%s killed at t = %.1f s (scheduled %s; %s)", self.name, t, self.kind, then)
        else:
            # The vehicle coasted on from its last recorded state (vehicles.coast): say since when.
            since = ""
            if resumed_from is not None:
                since = f"; it coasted without control since its state of t = {resumed_from:.1f} s"
            log.warning("%s restarted at t = %.1f s (scheduled %s%s)", self.name, t, self.kind, since)


def _process_actions(faults: Sequence[FaultSpec], t: float, dt: float) -> list[ProcessAction]:
    """Kills and restarts due at the step starting at t (kills before restarts)."""
    out = []
    by_kind = {"vehicle_kill": "vehicle", "broker_kill": "comms"}
    for fault, event in ((f, e) for f in faults for e in _events_at([f], t, dt) if e.kind in by_kind):
        target = by_kind[event.kind]
        vehicle = fault.vehicle if isinstance(fault, VehicleKillFault) else None
        if event.phase == "start":  # restarted at its step's time, as it is (an end at 9.05 s acts from 9.0 s)
            restart = steps_of_fault(fault, dt)[1]
            out.append(ProcessAction("kill", target, vehicle, None if restart is None else restart * dt))
        else:
            out.append(ProcessAction("restart", target, vehicle))
    return sorted(out, key=lambda a: a.action != "kill")

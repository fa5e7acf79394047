"""The scenario's faults ([[faults]]): one typed, frozen model per kind, told apart by `kind`.

A new fault kind: a model here, added to FaultSpec; its effect in supervisor/plan (ARCHITECTURE.md says where).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from supervisor.config.schema_base import (
    MAX_COUNT,
    MAX_DELAY,
    MAX_GAMMA,
    MAX_RATE,
    MAX_TIME,
    Float,
    Probability,
    Seconds,
    StrictModel,
    VehicleId,
)


class _Fault(StrictModel):
    """Every fault acts on [start, end); end none: to the end of the run."""

    start: Seconds = Field(description="when the fault begins, s")
    end: Seconds | None = Field(default=None, description="when it ends, s (after start; omitted: the end of the run)")


class SpeedCapFault(_Fault):
    """The paper's fault: vehicle's gamma_dot capped, its neighbours not told."""

    kind: Literal["speed_cap"]
    vehicle: VehicleId = Field(description="vehicle id")
    gamma_dot_max: Float = Field(
        ge=0, le=MAX_RATE, description="cap on its gamma_dot, unit of gamma per s (0: the vehicle holds still)"
    )


class LinkDownFault(_Fault):
    """A link fails: its packets are lost (reason link_down). both: the reverse direction too."""

    kind: Literal["link_down"]
    sender: VehicleId = Field(description="vehicle id")
    receiver: VehicleId = Field(description="vehicle id")
    both: bool = Field(default=True, description="the reverse direction too")


class LinkDegradedFault(_Fault):
    """A link gets worse: extra independent loss (reason degraded) and extra delay."""

    kind: Literal["link_degraded"]
    sender: VehicleId = Field(description="vehicle id")
    receiver: VehicleId = Field(description="vehicle id")
    both: bool = Field(default=True, description="the reverse direction too")
    extra_loss: Probability = Field(default=0.0, description="probability a packet is lost, on top")
    extra_delay: Float = Field(default=0.0, ge=0, le=MAX_DELAY, description="added to every packet's delay, s")


class BlackoutFault(_Fault):
    """Every packet is lost (reason blackout)."""

    kind: Literal["blackout"]


class ModemSilentFault(_Fault):
    """A vehicle's modem sends nothing, though the vehicle believes it does (reason modem_silent)."""

    kind: Literal["modem_silent"]
    vehicle: VehicleId = Field(description="vehicle id")


class GraphSwitchFault(_Fault):
    """The communication graph becomes `edges` (possibly disconnected); vehicles use their new neighbours."""

    kind: Literal["graph_switch"]
    edges: tuple[tuple[VehicleId, VehicleId], ...] = Field(
        max_length=MAX_COUNT, description="the new graph: pairs of vehicle ids (may be empty)"
    )


class VehicleKillFault(_Fault):
    """The vehicle's process is killed with SIGKILL at start and, if end is given, restarted then. Meanwhile the
    vehicle coasts: its plant with no control inputs, carried by its momentum and the current (vehicles.coast); the
    restarted controller starts at the path point nearest to where it got to. The kill is the fault, not a loss:
    the run goes on without the vehicle (to its restart, or to the end of the run without end) whatever
    scenario.on_vehicle_loss says, which is for deaths nobody scheduled. Both the kill and the restart are announced
    and recorded (cpf/run/fault, start and end)."""

    kind: Literal["vehicle_kill"]
    vehicle: VehicleId = Field(description="vehicle id")


class BrokerKillFault(_Fault):
    """The comms broker is killed with SIGKILL at start (packets in flight are lost: broker_down) and restarted at
    end (default: one step later)."""

    kind: Literal["broker_kill"]


class FrozenGammaFault(_Fault):
    """A faulty sensor: the vehicle keeps broadcasting the gamma and gamma_dot it had at start, restarted or not."""

    kind: Literal["frozen_gamma"]
    vehicle: VehicleId = Field(description="vehicle id")


class GammaOffsetFault(_Fault):
    """A faulty sensor: the vehicle broadcasts gamma + offset."""

    kind: Literal["gamma_offset"]
    vehicle: VehicleId = Field(description="vehicle id")
    offset: Float = Field(ge=-MAX_GAMMA, le=MAX_GAMMA, description="added to the gamma it broadcasts, unit of gamma")


class ClockSkewFault(_Fault):
    """The vehicle's clock runs `offset` s ahead (behind if negative): its messages carry skewed time stamps."""

    kind: Literal["clock_skew"]
    vehicle: VehicleId = Field(description="vehicle id")
    offset: Float = Field(
        ge=-MAX_TIME, le=MAX_TIME,
        description="its clock's error, s (positive: ahead); the time it stamps must stay within 0 .. 4294967.295 s, "
        "what the modem frame's u32 ms time stamp holds",
    )  # fmt: skip


FaultSpec = Annotated[
    SpeedCapFault
    | LinkDownFault
    | LinkDegradedFault
    | BlackoutFault
    | ModemSilentFault
    | GraphSwitchFault
    | VehicleKillFault
    | BrokerKillFault
    | FrozenGammaFault
    | GammaOffsetFault
    | ClockSkewFault,
    Field(discriminator="kind"),
]
LINK_FAULTS = (LinkDownFault, LinkDegradedFault)

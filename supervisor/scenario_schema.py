"""The scenario file's schema: typed, frozen pydantic models of every section.

Parsing, cross-field checks and one-line error messages live in supervisor/scenario.py.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, Strict, field_validator

from vehicles.coordination import Law
from vehicles.estimates import Predictor
from vehicles.params import PRESETS, VehicleParams

# Numbers as TOML writes them: an integer is a valid float, a string ("400") or a boolean is not a number.
Float = Annotated[float, Strict()]
Int = Annotated[int, Strict()]
Vec3 = tuple[Float, Float, Float]


class _Strict(BaseModel):
    # Lax mode so that TOML arrays become tuples; the numbers themselves are strict (Float, Int).
    # TOML has nan and inf literals; no field of a scenario may take them.
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False, allow_inf_nan=False)


class RunSection(_Strict):
    name: str
    description: str = ""
    duration: Float = Field(gt=0, description="simulated time, s")
    step: Float = Field(gt=0, description="integration and sync step, s")
    seed: Int = Field(default=0, ge=0)
    dimension: Literal[2, 3] = 3  # 3: the 6-DOF model; 2: the planar variant
    # A vehicle process that dies unscheduled: stop, or go on without it (a scheduled vehicle_kill never stops a run).
    on_vehicle_loss: Literal["abort", "continue"] = "abort"


class VehicleModelSection(_Strict):
    preset: str = "remus100"
    # Names and shapes (number or 3-vector) are checked against the preset by _check_overrides.
    overrides: dict[str, Float | Vec3] = {}

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, value: str) -> str:
        if value not in PRESETS:
            raise ValueError(f"unknown preset, expected one of {sorted(PRESETS)}")
        return value


class PathFollowingSection(_Strict):
    delta: Float = Field(default=-1.0, description="offset of the controlled point, m (its size: tube radius)")
    k1: Float = Field(default=0.5, gt=0)
    k2: Float = Field(default=1.0, gt=0)
    k_zeta: Float = Field(default=1.0, gt=0)

    @field_validator("delta")
    @classmethod
    def _nonzero(cls, value: float) -> float:
        if value == 0.0:
            raise ValueError("must be non-zero (delta = 0 leaves the pitch and yaw rates unsteerable)")
        return value


class CoordinationSection(_Strict):
    law: Law = "corrected"
    k: Float = Field(default=0.2, gt=0)
    k2: Float = Field(default=1.0, gt=0)
    v_r: Float = Field(default=1.0, description="reference speed of the path parameters, 1/s")
    predictor: Predictor = "first_order"


class GraphSection(_Strict):
    edges: tuple[tuple[Int, Int], ...]


class HelixPath(_Strict):
    type: Literal["helix"]
    radius: Float = Field(gt=0)
    climb: Float
    period: Float
    phase: Float = 0.0
    center: Vec3 = (0.0, 0.0, 0.0)


class CirclePath(_Strict):
    type: Literal["circle"]
    radius: Float = Field(gt=0)
    period: Float
    phase: Float = 0.0
    center: Vec3 = (0.0, 0.0, 0.0)


class LinePath(_Strict):
    type: Literal["line"]
    start: Vec3
    velocity: Vec3


class LawnmowerPath(_Strict):
    type: Literal["lawnmower"]
    origin: Vec3
    leg_length: Float = Field(gt=0)
    spacing: Float = Field(gt=0)
    legs: Int = Field(ge=1, le=10_000)  # the path is built leg by leg when the scenario is checked
    heading: Float = 0.0
    scale: Float = Field(default=1.0, gt=0)


PathSpec = Annotated[HelixPath | CirclePath | LinePath | LawnmowerPath, Field(discriminator="type")]


class VehicleSection(_Strict):
    id: Int = Field(ge=1)
    position: Vec3
    attitude_rpy_deg: Vec3 = (0.0, 0.0, 0.0)
    velocity: Vec3 = (0.0, 0.0, 0.0)
    angular_velocity: Vec3 = (0.0, 0.0, 0.0)
    gamma0: Float | Literal["closest"] = "closest"
    path: PathSpec


class _Fault(_Strict):
    """Every fault acts on [start, end); end none: to the end of the run."""

    start: Float = Field(ge=0, description="s")
    end: Float | None = Field(default=None, description="s")


class SpeedCapFault(_Fault):
    """The paper's fault: vehicle's gamma_dot capped, its neighbours not told."""

    kind: Literal["speed_cap"]
    vehicle: Int
    gamma_dot_max: Float


class LinkDownFault(_Fault):
    """A link fails: its packets are lost (reason link_down). both: the reverse direction too."""

    kind: Literal["link_down"]
    sender: Int
    receiver: Int
    both: bool = True


class LinkDegradedFault(_Fault):
    """A link gets worse: extra independent loss (reason degraded) and extra delay."""

    kind: Literal["link_degraded"]
    sender: Int
    receiver: Int
    both: bool = True
    extra_loss: Float = Field(default=0.0, ge=0, le=1)
    extra_delay: Float = Field(default=0.0, ge=0, description="s")


class BlackoutFault(_Fault):
    """Every packet is lost (reason blackout)."""

    kind: Literal["blackout"]


class ModemSilentFault(_Fault):
    """A vehicle's modem sends nothing, though the vehicle believes it does (reason modem_silent)."""

    kind: Literal["modem_silent"]
    vehicle: Int


class GraphSwitchFault(_Fault):
    """The communication graph becomes `edges` (possibly disconnected); vehicles use their new neighbours."""

    kind: Literal["graph_switch"]
    edges: tuple[tuple[Int, Int], ...]


class VehicleKillFault(_Fault):
    """The vehicle's process is killed with SIGKILL at start and, if end is given, restarted then from its last
    recorded state. The kill is the fault, not a loss: the run goes on without the vehicle (to its restart, or to
    the end of the run without end) whatever scenario.on_vehicle_loss says, which is for deaths nobody scheduled.
    Both the kill and the restart are announced and recorded (cpf/run/fault, start and end)."""

    kind: Literal["vehicle_kill"]
    vehicle: Int


class BrokerKillFault(_Fault):
    """The comms broker is killed with SIGKILL at start (packets in flight are lost: broker_down) and restarted at
    end (default: one step later)."""

    kind: Literal["broker_kill"]


class FrozenGammaFault(_Fault):
    """A faulty sensor: the vehicle keeps broadcasting the gamma and gamma_dot it had at start."""

    kind: Literal["frozen_gamma"]
    vehicle: Int


class GammaOffsetFault(_Fault):
    """A faulty sensor: the vehicle broadcasts gamma + offset."""

    kind: Literal["gamma_offset"]
    vehicle: Int
    offset: Float


class ClockSkewFault(_Fault):
    """The vehicle's clock runs `offset` s ahead (behind if negative): its messages carry skewed time stamps."""

    kind: Literal["clock_skew"]
    vehicle: Int
    offset: Float


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


class WaterSection(_Strict):
    """Sound speed from Mackenzie's equation (valid for T 2-30 C, S 25-40 ppt, D 0-8000 m)."""

    temperature: Float = Field(ge=2, le=30, description="deg C")
    salinity: Float = Field(default=35.0, ge=25, le=40, description="ppt")
    depth: Float = Field(default=0.0, ge=0, le=8000, description="m")


class BurstSection(_Strict):
    """Gilbert-Elliott loss given as its long-run loss rate and mean burst length (packets)."""

    mean_loss: Float = Field(ge=0, lt=1)
    mean_burst: Float = Field(ge=1)


class LinkBudgetSection(_Strict):
    """Range-dependent loss from the link budget; carrier, bandwidth and modulation come from the modem."""

    type: Literal["link_budget"]
    source_level: Float = Field(description="dB re 1 uPa at 1 m")
    spreading: Float = Field(default=1.5, ge=1, le=2)
    shipping: Float = Field(default=0.5, ge=0, le=1)
    wind: Float = Field(default=0.0, ge=0, description="m/s")
    directivity: Float = Field(default=0.0, description="dB")


class RangeTableSection(_Strict):
    """Range-dependent loss from a table of packet success probability against range (m)."""

    type: Literal["table"]
    ranges: tuple[Float, ...] = Field(min_length=1)
    success: tuple[Float, ...] = Field(min_length=1)


RangeSpec = Annotated[LinkBudgetSection | RangeTableSection, Field(discriminator="type")]


class LinkSection(_Strict):
    """One directed link's own loss and extra delay (its loss and burst replace the fleet-wide ones)."""

    sender: Int
    receiver: Int
    loss: Float | None = Field(default=None, ge=0, le=1)
    burst: BurstSection | None = None
    extra_delay: Float = Field(default=0.0, ge=0, description="s")


class TransmitSection(_Strict):
    """When vehicles transmit: periodically, or when their gamma leaves what their neighbours predict."""

    policy: Literal["periodic", "event"] = "periodic"
    period: Float | None = Field(default=None, gt=0, description="periodic: s between messages; none: every step")
    threshold: Float = Field(default=0.05, gt=0, description="event: c0 of h(t) = c0 + c1 exp(-alpha t)")
    threshold_decay: Float = Field(default=0.0, ge=0, description="event: c1")
    decay_rate: Float = Field(default=0.0, ge=0, description="event: alpha, 1/s")
    min_interval: Float = Field(default=0.0, ge=0, description="event: s between messages at least")
    heartbeat: Float | None = Field(default=None, gt=0, description="event: s between messages at most")


class TdmaSection(_Strict):
    slot: Float = Field(gt=0, description="s; must hold a packet's airtime plus the longest propagation delay")
    order: tuple[Int, ...] | None = None  # slot owners in order; default: vehicle ids as listed


class CommsSection(_Strict):
    """The acoustic channel between vehicles (comms/channel.py). Defaults: the ideal channel."""

    sound_speed: Float | WaterSection = Field(default=1500.0, description="m/s, or water properties")
    modem: str = "ideal"
    bitrate: Float | None = Field(default=None, gt=0, description="bit/s, overrides the modem's")
    preamble: Float | None = Field(default=None, ge=0, description="s, overrides the modem's")
    frame_bytes: Int | None = Field(default=None, gt=0)
    half_duplex: bool | None = None
    collisions: bool | None = None
    packet_bytes: Int | None = Field(default=None, gt=0, description="none: the encoded message size (15 B)")
    jitter: Float = Field(default=0.0, ge=0, description="extra delay, uniform on [0, jitter], s")
    loss: Float = Field(default=0.0, ge=0, le=1, description="independent (Bernoulli) loss per directed link")
    burst: BurstSection | None = None
    range: RangeSpec | None = None
    links: tuple[LinkSection, ...] = ()
    transmit: TransmitSection = TransmitSection()
    tdma: TdmaSection | None = None
    stats_window: Float = Field(default=10.0, gt=0, description="s: link statistics and delivered lambda_2")

    @field_validator("modem")
    @classmethod
    def _known_modem(cls, value: str) -> str:
        from comms.modem import PRESETS as MODEMS

        if value not in MODEMS:
            raise ValueError(f"unknown modem {value!r}, expected one of {sorted(MODEMS)}")
        return value


class ReportSection(_Strict):
    transient: Float = Field(default=50.0, ge=0, description="initial time left out of path-following stats, s")
    tube_margin: Float = Field(default=0.2, ge=0, description="allowed excess over |delta| in the tube, m")
    coordination_tolerance: Float = Field(default=0.01, gt=0)


class Scenario(_Strict):
    scenario: RunSection
    vehicle: VehicleModelSection = VehicleModelSection()
    path_following: PathFollowingSection = PathFollowingSection()
    coordination: CoordinationSection = CoordinationSection()
    graph: GraphSection
    vehicles: tuple[VehicleSection, ...] = Field(min_length=2)
    comms: CommsSection = CommsSection()
    faults: tuple[FaultSpec, ...] = ()
    report: ReportSection = ReportSection()

    @property
    def vehicle_ids(self) -> list[int]:
        return [v.id for v in self.vehicles]

    def vehicle_params(self) -> VehicleParams:
        from vehicles.params import preset

        return preset(self.vehicle.preset, **self.vehicle.overrides)

    def neighbours(self, vehicle_id: int) -> list[int]:
        """N_i of the scenario's graph, in ascending order."""
        out = {j for i, j in self.graph.edges if i == vehicle_id} | {i for i, j in self.graph.edges if j == vehicle_id}
        return sorted(out)

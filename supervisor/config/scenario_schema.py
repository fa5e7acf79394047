"""The scenario file's schema: typed, frozen pydantic models of every section.

Parsing, cross-field checks and one-line error messages live in supervisor/config/scenario.py; the faults' models in
supervisor/config/fault_schema.py (re-exported here), the number types and the strict base in
supervisor/config/schema_base.py.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, field_validator

from supervisor.config import plant_schema
from supervisor.config.comms_schema import (
    BurstSection,
    CommsSection,
    LinkBudgetSection,
    LinkSection,
    RangeTableSection,
    TdmaSection,
    TransmitSection,
    WaterSection,
)
from supervisor.config.fault_schema import (
    LINK_FAULTS,
    BlackoutFault,
    BrokerKillFault,
    ClockSkewFault,
    FaultSpec,
    FrozenGammaFault,
    GammaOffsetFault,
    GraphSwitchFault,
    LinkDegradedFault,
    LinkDownFault,
    ModemSilentFault,
    SpeedCapFault,
    VehicleKillFault,
)
from supervisor.config.navigation_schema import NavigationSection
from supervisor.config.plant_schema import UNCERTAINTY_DESCRIPTION, EnvironmentSection, Uncertainty, as_any_of
from supervisor.config.saturation_schema import SaturationSection
from supervisor.config.schema_base import (
    MAX_COUNT,
    MAX_FLEET,
    MAX_GAIN,
    MAX_GAMMA,
    MAX_LENGTH,
    MAX_RATE,
    MAX_TIME,
    MIN_STEP,
    Degrees,
    ExtensionName,
    Float,
    Int,
    Position,
    Rate,
    RenamedKeys,
    Speed,
    StrictModel,
    Vec3,
    VehicleId,
    one_of,
    radians,
)
from vehicles.params import PRESETS, VehicleParams

__all__ = [
    "LINK_FAULTS",
    "BlackoutFault",
    "BrokerKillFault",
    "BurstSection",
    "ClockSkewFault",
    "CommsSection",
    "FaultSpec",
    "Float",
    "FrozenGammaFault",
    "GammaOffsetFault",
    "GraphSwitchFault",
    "Int",
    "LinkBudgetSection",
    "LinkDegradedFault",
    "LinkDownFault",
    "LinkSection",
    "ModemSilentFault",
    "RangeTableSection",
    "SaturationSection",
    "Scenario",
    "SpeedCapFault",
    "TdmaSection",
    "TransmitSection",
    "Vec3",
    "VehicleKillFault",
    "WaterSection",
]


NAME_PATTERN = r"^[A-Za-z0-9_+-][A-Za-z0-9_.+-]*$"
PERIOD = "units of gamma per revolution; at least 1e-6 in size, negative turns clockwise from above"
PHASE = "angle at gamma = 0, rad (from +x towards +y)"


class RunSection(StrictModel):
    """The run as a whole: its name, how long and in what steps it is simulated, the random seed and the model."""

    # A name, not a path: the default log is runs/<name>.mcap, and "../x" must not write outside runs/.
    name: str = Field(
        pattern=NAME_PATTERN, max_length=100,
        description="names the run: the default log is runs/<name>.mcap; letters, digits, '_', '-', '.', '+' "
        "(a name, not a path: no '/', not starting with '.')",
    )  # fmt: skip
    description: str = Field(default="", max_length=1000, description="one line for people; shown by cpf info")
    duration: Float = Field(
        gt=0, le=MAX_TIME, description="simulated time, s (at most what the modem frame's u32 ms time stamp holds)"
    )
    step: Float = Field(
        ge=MIN_STEP, le=MAX_TIME,
        description="integration and sync step, s (at least 1 ms, the modem frame's time resolution; the run is "
        "at most 10 000 000 steps)",
    )  # fmt: skip
    seed: Int = Field(
        default=0, ge=0, le=2**64 - 1, description="seed of every random stream (loss, jitter); cpf run --seed wins"
    )
    dimension: Literal[2, 3] = Field(
        default=3, description="3: the 6-DOF model of eqs. (1)-(2); 2: the planar variant (x, y and yaw only)"
    )
    on_vehicle_loss: Literal["abort", "continue"] = Field(
        default="abort",
        description=(
            "a vehicle process that dies unscheduled: stop the run (abort), or go on without it "
            "(a scheduled vehicle_kill never stops a run)"
        ),
    )


class VehicleModelSection(StrictModel):
    """The vehicle model every AUV of the fleet uses: a named preset (cpf presets lists them) and changes to it, or
    another model (`model`)."""

    preset: str = Field(default="remus100", description="vehicle preset", json_schema_extra=one_of(PRESETS))
    # Names and shapes (number or 3-vector) are checked against the preset by _check_overrides.
    overrides: dict[str, Float | Vec3] = Field(
        default={},
        max_length=50,
        description=f"parameter = value, replacing the preset's; names: {', '.join(VehicleParams.__dataclass_fields__)}"
        " (units: kg, kg m^2, N s/m, N s^2/m^2, N m s, N m s^2, N, m; 3 numbers for the diagonal ones; mass also as one"
        " number: the rigid body's, as `cpf presets` shows it, added mass and trim kept; `cpf presets NAME` lists a"
        " preset's values)",
    )
    uncertainty: Uncertainty = Field(default=0.0, description=UNCERTAINTY_DESCRIPTION, json_schema_extra=as_any_of)
    actuators: plant_schema.Actuation = Field(
        default="preset", description=plant_schema.ACTUATORS, json_schema_extra=as_any_of
    )
    model: ExtensionName | None = Field(
        default=None, description="another vehicle model for the whole fleet, instead of the preset: an installed "
        "extension's name (`cpf plugins`) or package.module:Name; absent: the preset (with its overrides)",
    )  # fmt: skip
    model_options: dict[str, Any] = Field(default_factory=dict, description="that model's own options (its fields)")

    _known_preset = field_validator("preset")(lambda value: plant_schema.known_preset(value))


class PathFollowingSection(StrictModel):
    """Each vehicle's path-following controller: the delta-shifted backstepping design with its gains, or another."""

    controller: ExtensionName = Field(
        default="auto",
        description="auto (per vehicle: line_of_sight on fins, as the remus100 preset's; else supervisory where "
        "vehicle.uncertainty makes inertia or damping uncertain, else backstepping), backstepping, supervisory "
        "(Aguiar & Hespanha 2007), line_of_sight (bounded demands and a disturbance observer: "
        "vehicles/line_of_sight.py), an extension (cpf plugins), pkg.mod:Name",
    )
    controller_options: dict[str, Any] = Field(
        default_factory=dict, description="a named controller's options (its fields; auto and backstepping take none)"
    )
    delta: Float = Field(
        default=-1.0, ge=-100, le=100,
        description="the controller steers the point at -delta along the body x axis onto the path, m (negative: "
        "the point |delta| ahead of the vehicle, which trails its path point; its size is the tube radius); non-zero",
    )  # fmt: skip
    k1: Float = Field(default=0.5, gt=0, le=MAX_GAIN, description="K1: gain on the position error, m/s")
    k2: Float = Field(default=1.0, gt=0, le=MAX_GAIN, description="K2: gain on the velocity error, 1/s")
    k_zeta: Float = Field(default=1.0, gt=0, le=MAX_GAIN, description="gain on the speed error gamma_dot - v_r, 1/s")
    damping: Literal["feedforward", "cancel"] = Field(
        default="feedforward",
        description="how the model's damping of surge, pitch and yaw rate enters the inputs: feedforward (at the "
        "velocity the controller asks for; the vehicle's own damping acts on the error, robust to a wrong model) or "
        "cancel (at the measured velocity: the nominal model inverted exactly, the former default)",
    )

    @field_validator("delta")
    @classmethod
    def _nonzero(cls, value: float) -> float:
        if value == 0.0:
            raise ValueError("must be non-zero (delta = 0 leaves the pitch and yaw rates unsteerable)")
        return value


class CoordinationSection(StrictModel):
    """How the fleet synchronises the path parameters gamma_i over the communication graph: the coordination law, how
    each vehicle predicts its neighbours between messages, and the gains of law (5)."""

    law: ExtensionName = Field(
        default="corrected",
        description="the coordination law: corrected (law (5) on the speed error gamma_dot - v_r, settles at v_r), "
        "literal (law (5) as printed, settles at k_zeta v_r / (k_zeta + k2)), saturated (a bounded correction from "
        "the gamma disagreement alone, Rego et al. 2019), wmsr (law (5) resilient to F lying neighbours, LeBlanc et "
        "al. 2013; the graph must be (2F + 1)-robust: docs/resilience.md), an installed extension's name "
        "(`cpf plugins`), or "
        "package.module:Name",
    )
    law_options: dict[str, Any] = Field(
        default_factory=dict, description="the law's own options (its fields; saturated: k_c, width; wmsr: f)"
    )
    k: Float = Field(
        default=0.2, gt=0, le=MAX_GAIN, description="K = diag(k): gain on the disagreement with neighbours, 1/s"
    )
    k2: Float = Field(default=1.0, gt=0, le=MAX_GAIN, description="K2 = diag(k2), 1/s")
    schedule: Literal["rate", "none"] = Field(
        default="rate",
        description="how k meets the links: rate (law (5) with a built-in predictor: k is lowered, if the links are "
        "slow or late, to the gain at which the predicted coordination error decays fastest, cpf stability; "
        "docs/stability.md), none (k as given)",
    )
    v_r: Float = Field(
        default=1.0, ge=-MAX_RATE, le=MAX_RATE,
        description="reference speed of the path parameters, unit of gamma per s (the speed it asks of each vehicle "
        "along its path must not exceed 100 m/s)",
    )  # fmt: skip
    predictor: ExtensionName = Field(
        default="reference",
        description="how a neighbour's gamma is predicted between messages: first_order (gamma + gamma_dot age, "
        "option horizon: at most that many s), hold (last value), reference (gamma + v_r age), an installed "
        "extension's name, or package.module:Name",
    )
    predictor_options: dict[str, Any] = Field(
        default_factory=dict, description="the predictor's own options (its fields; first_order: horizon, s)"
    )
    max_age: Float | None = Field(
        default=None, gt=0, le=MAX_TIME,
        description="s after which a neighbour's estimate stops counting in the law, until it is heard again "
        "(a switching topology); omitted: estimates never expire",
    )  # fmt: skip


class GraphSection(StrictModel):
    """The communication graph: who hears whom (undirected; must be connected)."""

    edges: tuple[tuple[VehicleId, VehicleId], ...] = Field(
        max_length=MAX_COUNT, description="pairs of vehicle ids, e.g. [[1, 2], [1, 3]]"
    )


MIN_PERIOD = 1e-6  # units of gamma: a shorter period makes the path's derivatives overflow


def _period(value: float) -> float:
    if abs(value) < MIN_PERIOD:
        raise ValueError(f"must be non-zero and at least {MIN_PERIOD:g} in size")
    return value


class HelixPath(RenamedKeys):
    """p_d(gamma) = center + [radius cos(2 pi gamma / period + phase_rad), radius sin(2 pi gamma / period + phase_rad),
    climb gamma]. gamma counts revolutions in units of 1/period: one turn per `period` units of gamma (with period =
    2 pi, gamma is the angle in rad); at gamma_dot = v_r a vehicle moves at v_r sqrt((2 pi radius / period)^2 +
    climb^2) m/s."""

    type: Literal["helix"]
    radius: Float = Field(gt=0, le=MAX_LENGTH, description="m")
    climb: Float = Field(ge=-MAX_LENGTH, le=MAX_LENGTH, description="m of height per unit of gamma (z up; 0: a circle)")
    period: Float = Field(ge=-MAX_GAMMA, le=MAX_GAMMA, description=PERIOD)
    phase_rad: Float = radians("phase", PHASE)
    center: Position = Field(default=(0.0, 0.0, 0.0), description="[x, y, z] of the axis at gamma = 0, m")

    _period_size = field_validator("period")(_period)


class CirclePath(RenamedKeys):
    """A horizontal circle at height center[2]: the helix with climb 0. gamma counts revolutions in units of
    1/period (with period = 2 pi, gamma is the angle in rad: vehicles on circles of different radii are abreast
    when their gammas agree, the paper's Fig. 2); at gamma_dot = v_r a vehicle moves at 2 pi radius v_r / period
    m/s."""

    type: Literal["circle"]
    radius: Float = Field(gt=0, le=MAX_LENGTH, description="m")
    period: Float = Field(ge=-MAX_GAMMA, le=MAX_GAMMA, description=PERIOD)
    phase_rad: Float = radians("phase", PHASE)
    center: Position = Field(default=(0.0, 0.0, 0.0), description="[x, y, z] of the centre, m")

    _period_size = field_validator("period")(_period)


class LinePath(StrictModel):
    """p_d(gamma) = start + gamma velocity. gamma is distance along the line in units of |velocity| m (a unit
    velocity makes gamma metres, and v_r m/s)."""

    type: Literal["line"]
    start: Position = Field(description="[x, y, z] at gamma = 0, m")
    velocity: Position = Field(description="[x, y, z] m per unit of gamma; at least 1e-6 m in size")


class LawnmowerPath(RenamedKeys):
    """A survey pattern in the plane z = origin[2]: `legs` parallel legs joined by half-circle turns of radius
    spacing / 2, advancing to the left of the first leg. gamma = arc length / scale (scale = 1: gamma in metres of
    path, v_r in m/s); before gamma = 0 and after the last leg the path goes on straight."""

    type: Literal["lawnmower"]
    origin: Position = Field(description="[x, y, z] where the first leg starts (gamma = 0), m")
    leg_length: Float = Field(gt=0, le=MAX_LENGTH, description="m")
    spacing: Float = Field(gt=0, le=MAX_LENGTH, description="distance between legs, m")
    # The path is built leg by leg when the scenario is checked: hence the bound.
    legs: Int = Field(ge=1, le=10_000, description="number of legs")
    heading_rad: Float = radians("heading", "direction of the first leg, rad (from +x towards +y)")
    scale: Float = Field(default=1.0, gt=0, le=MAX_LENGTH, description="m of path per unit of gamma")


PathSpec = Annotated[HelixPath | CirclePath | LinePath | LawnmowerPath, Field(discriminator="type")]


class VehicleSection(StrictModel):
    """One AUV: its id, where it starts and the path it follows."""

    id: VehicleId = Field(description="vehicle id, unique, at most 65535 (2 bytes on the wire if one is over 255)")
    position: Position = Field(description="initial [x, y, z], m (z up)")
    attitude_rpy_deg: tuple[Degrees, Degrees, Degrees] = Field(
        default=(0.0, 0.0, 0.0), description="initial roll, pitch, yaw, deg"
    )
    velocity: tuple[Speed, Speed, Speed] = Field(
        default=(0.0, 0.0, 0.0), description="initial body velocity [u, v, w], m/s"
    )
    angular_velocity: tuple[Rate, Rate, Rate] = Field(
        default=(0.0, 0.0, 0.0), description="initial body rates [p, q, r], rad/s"
    )
    gamma0: Annotated[Float, Field(ge=-MAX_GAMMA, le=MAX_GAMMA)] | Literal["closest"] = Field(
        default="closest",
        description="initial path parameter (the path's unit), or closest: the gamma of the path's point nearest the "
        "vehicle, on a circle or helix within half a period of the first [[vehicles]]'s gamma0 (if closest too, its "
        "nearest within half a period of 0), on a line or lawnmower anywhere; of ties, the nearest that gamma0",
    )
    path: PathSpec = Field(description="the path p_d(gamma): a table with type = helix, circle, line or lawnmower")
    preset: str | None = Field(
        default=None, description="this vehicle's preset (a mixed fleet); absent: [vehicle] preset",
        json_schema_extra=one_of(PRESETS),
    )  # fmt: skip
    overrides: dict[str, Float | Vec3] = Field(  # names and shapes: held to its preset's (scenario_checks._overrides)
        default={}, max_length=50,
        description="parameter = value for this vehicle, applied after [vehicle] overrides (same names and units)",
    )  # fmt: skip

    _known_preset = field_validator("preset")(lambda value: plant_schema.known_preset(value))


class ReportSection(StrictModel):
    """What the run summary and cpf report measure against."""

    transient: Float = Field(
        default=50.0, ge=0, le=MAX_TIME, description="initial time left out of path-following stats, s"
    )
    tube_margin: Float = Field(
        default=0.2, ge=0, le=MAX_LENGTH, description="allowed excess over |delta| in the tube, m"
    )
    coordination_tolerance: Float = Field(
        default=0.01,
        gt=0,
        le=MAX_GAMMA,
        description="max|gamma_i - gamma_j| below which the fleet counts as coordinated",
    )


class Scenario(StrictModel):
    """A cpf-cosim scenario file (TOML). Lengths in m, times in s, angles in rad unless the name says deg."""

    scenario: RunSection
    vehicle: VehicleModelSection = VehicleModelSection()
    path_following: PathFollowingSection = PathFollowingSection()
    coordination: CoordinationSection = CoordinationSection()
    graph: GraphSection
    vehicles: tuple[VehicleSection, ...] = Field(
        min_length=2, max_length=MAX_FLEET, description="the fleet: one [[vehicles]] per AUV"
    )
    comms: CommsSection = CommsSection()
    faults: tuple[FaultSpec, ...] = Field(
        default=(), max_length=10_000, description="the fault schedule: one [[faults]] per fault"
    )
    report: ReportSection = ReportSection()
    environment: EnvironmentSection = EnvironmentSection()
    navigation: NavigationSection | None = Field(
        default=None, description="navigation sensors and filter (absent: every controller sees the true state)"
    )
    saturation: SaturationSection = SaturationSection()

    @property
    def vehicle_ids(self) -> list[int]:
        return [v.id for v in self.vehicles]

    def neighbours(self, vehicle_id: int) -> list[int]:
        """N_i of the scenario's graph, in ascending order."""
        out = {j for i, j in self.graph.edges if i == vehicle_id} | {i for i, j in self.graph.edges if j == vehicle_id}
        return sorted(out)

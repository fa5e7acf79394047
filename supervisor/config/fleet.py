"""From a validated Scenario to what each vehicle runs: its VehicleConfig and its initial VehicleState.

Used by both engines (and by a vehicle process, which builds only its own), so vehicles start identically.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from comms.broker.broker_core import BrokerCore
from comms.broker.stats import LinkStats
from comms.channel.channel import Capture, Channel, ChannelParams, LinkParams
from comms.channel.loss import (
    Bernoulli,
    Composite,
    GilbertElliott,
    GilbertElliottTime,
    LinkBudgetRange,
    LossModel,
    RangeTable,
)
from comms.channel.modem import ModemParams
from comms.records.messages import Message
from comms.records.state import StateReport
from comms.records.wire import wide_for
from supervisor.config.controller_choice import controller_name, controller_options
from supervisor.config.derived import stuck_spans
from supervisor.config.extensions import extension
from supervisor.config.links import held_to_frames, needs_fitting, tdma_schedule
from supervisor.config.medium import modem_params, sound_speed
from supervisor.config.per_scenario import per_scenario
from supervisor.config.plant import actuators_of, current_of, plant_of
from supervisor.config.scenario_schema import (
    BurstSection,
    CirclePath,
    CommsSection,
    FaultSpec,
    HelixPath,
    LawnmowerPath,
    LinePath,
    LinkBudgetSection,
    LinkSection,
    PathSpec,
    RangeTableSection,
    Scenario,
    VehicleSection,
)
from supervisor.config.vehicle_models import top_speed_of, vehicle_of
from vehicles.actuators import Actuators
from vehicles.agent import VehicleConfig, VehicleState
from vehicles.coast import resumed
from vehicles.coordination import CoordinationGains
from vehicles.current_observer import CurrentObserver
from vehicles.dynamics import PLANAR, SPATIAL, Model
from vehicles.estimates import NeighbourEstimate, Predictor
from vehicles.geometry import rotation_2d, rotation_from_rpy
from vehicles.navigation import NavParams
from vehicles.nearest import nearest_gamma
from vehicles.path_following import PathFollowingController
from vehicles.paths import Circle, Helix, Lawnmower, Line, Path
from vehicles.runtime import NodeState, Radio
from vehicles.saturation import coordination_acceleration
from vehicles.transmission import Policy


def build_path(spec: PathSpec) -> Path:
    if isinstance(spec, HelixPath):
        return Helix(spec.radius, spec.climb, spec.period, spec.phase_rad, spec.center)
    if isinstance(spec, CirclePath):
        return Circle(spec.radius, spec.period, spec.phase_rad, spec.center)
    if isinstance(spec, LinePath):
        return Line(spec.start, spec.velocity)
    assert isinstance(spec, LawnmowerPath)
    return Lawnmower(spec.origin, spec.leg_length, spec.spacing, spec.legs, spec.heading_rad, spec.scale)


def model_of(scenario: Scenario) -> Model:
    return SPATIAL if scenario.scenario.dimension == 3 else PLANAR


def vehicle_config(scenario: Scenario, vehicle_id: int, seed: int | None = None) -> VehicleConfig:
    """seed: the run's (cpf run --seed); None: the scenario's."""
    section = _section(scenario, vehicle_id)
    co = scenario.coordination
    vehicle = vehicle_of(scenario, vehicle_id)
    params = vehicle.parameters()
    run_seed = scenario.scenario.seed if seed is None else seed
    actuators = actuators_of(scenario, vehicle_id, params)
    return VehicleConfig(
        vehicle_id=vehicle_id,
        model=model_of(scenario),
        params=params,
        path=build_path(section.path),
        controller=controller_of(scenario, vehicle_id, actuators),
        coordination=CoordinationGains(coupling_k(scenario), co.k2, co.v_r),
        predictor=predictor_of(scenario),
        law=extension("law", co.law, co.law_options),
        max_age=co.max_age,
        plant=plant_of(scenario, vehicle_id, run_seed),
        current=current_of(scenario),
        current_known=scenario.environment.current_known,
        current_observer=current_observer_of(scenario),
        navigation=nav_params(scenario, vehicle_id, run_seed),
        top_speed=top_speed_of(scenario, vehicle_id),
        correction_limit=_given(scenario.saturation.correction),
        correction_acceleration=(
            coordination_acceleration(params) if scenario.saturation.correction == "preset" else None
        ),
        vehicle_model=vehicle,
        actuators=actuators,
    )


@per_scenario
def coupling_k(scenario: Scenario) -> float:
    """The k law (5) runs with (supervisor.config.stability.scenario.coupling_gain), the analysis and its scipy
    imported only where k must be fitted to the links; once per scenario (every vehicle's configuration needs it)."""
    if not needs_fitting(scenario):
        return scenario.coordination.k
    from supervisor.config.stability.scenario import coupling_gain

    return coupling_gain(scenario)


def _given(value: float | str) -> float | None:
    return value if isinstance(value, float) else None


def nav_params(scenario: Scenario, vehicle_id: int, seed: int) -> NavParams | None:
    """The vehicle's navigation sensors, None if the scenario has none (the controller sees the truth)."""
    nav = scenario.navigation
    if nav is None:
        return None
    return NavParams(
        seed, vehicle_id, nav.dvl_noise, nav.dvl_bias, math.radians(nav.heading_noise_deg), nav.depth_noise,
        nav.fix_period, nav.fix_noise, nav.fix_dropout, nav.initial_error, planar=scenario.scenario.dimension == 2,
    )  # fmt: skip


def initial_state(scenario: Scenario, config: VehicleConfig) -> VehicleState:
    """The vehicle at rest (or as given) at t = 0, at its initial gamma (initial_gamma)."""
    section = _section(scenario, config.vehicle_id)
    roll, pitch, yaw = (math.radians(a) for a in section.attitude_rpy_deg)
    position = np.array(section.position, dtype=float)
    if config.model.dim == 3:
        rot = rotation_from_rpy(roll, pitch, yaw)
        x = SPATIAL.pack(position, rot, np.array(section.velocity), np.array(section.angular_velocity))
    else:
        rot = rotation_2d(yaw)
        x = PLANAR.pack(position[:2], rot, np.array(section.velocity[:2]), np.array(section.angular_velocity[2:]))
    return VehicleState(t=0.0, x=x, gamma=initial_gamma(scenario, config.vehicle_id), gamma_dot=0.0)


def initial_gamma(scenario: Scenario, vehicle_id: int) -> float:
    """The vehicle's gamma0: as given, or for gamma0 = "closest" the gamma of its path's point nearest its start,
    searched where the fleet agrees on it (vehicles.nearest.nearest_gamma). The reference gamma is the first
    [[vehicles]] entry's gamma0: its given number, or its nearest point within half a period of gamma = 0 (on a
    circle or helix; on a line or lawnmower, the nearest point of the whole path). Every other vehicle on a circle or
    helix then takes its nearest point within half a period of that reference, so vehicles started side by side
    start on the same lap, with nearly equal gammas; a vehicle on a line or lawnmower takes the nearest point of its
    whole path. Equally near points: the one nearest the reference."""
    section = _section(scenario, vehicle_id)
    if section.gamma0 != "closest":
        return float(section.gamma0)
    first = scenario.vehicles[0]
    reference = _nearest(scenario, first, 0.0) if first.gamma0 == "closest" else float(first.gamma0)
    return reference if section.id == first.id else _nearest(scenario, section, reference)


def _nearest(scenario: Scenario, section: VehicleSection, reference: float) -> float:
    path = build_path(section.path)
    target = np.array(section.position, dtype=float)
    if scenario.scenario.dimension == 2:  # a planar vehicle ignores z: measure in the path's own plane
        target[2] = _path_height(path)
    return nearest_gamma(path, target, reference)


def _path_height(path: Path) -> float:
    return float(path.evaluate(0.0)[0][2])


def _section(scenario: Scenario, vehicle_id: int) -> VehicleSection:
    return next(v for v in scenario.vehicles if v.id == vehicle_id)


def range_model(scenario: Scenario, radio_modem: ModemParams) -> LossModel | None:
    spec = scenario.comms.range
    if isinstance(spec, LinkBudgetSection):
        return _builtin(
            LinkBudgetRange, source_level_db=spec.source_level, frequency_khz=radio_modem.frequency_khz,
            bandwidth_hz=radio_modem.bandwidth_hz, modulation=radio_modem.modulation, spreading=spec.spreading,
            shipping=spec.shipping, wind_m_s=spec.wind, directivity_db=spec.directivity,
            bitrate=radio_modem.bitrate if spec.ebn0 == "bitrate" else None,
            frame_bytes=radio_modem.frame_bytes if spec.bits == "frame" else None,
            shadowing_db=spec.shadowing, shadowing_time=spec.shadowing_time, rician_k=spec.rician_k,
        )  # fmt: skip
    if isinstance(spec, RangeTableSection):
        return _builtin(RangeTable, ranges_m=spec.ranges, success=spec.success)
    return None


def _builtin(cls: type, **options: Any) -> LossModel:
    """One of cpf-cosim's loss models for the scenario's own keys (range, loss, burst), found and built as any
    extension is: by its import path, so that those keys work where the cpf.loss entry points are not installed
    (a source checkout on PYTHONPATH)."""
    model: LossModel = extension("loss", f"{cls.__module__}:{cls.__qualname__}", options)
    return model


def _loss_model(
    range_model: LossModel | None, loss: float, burst: BurstSection | None, named: LossModel | None
) -> LossModel | None:
    """The models that act on one link, composed: range first, then independent, then bursty loss, then the one
    comms.loss_model names. They share the link's random stream, each drawing its numbers in that order at every
    packet: without a named model the draws are what they always were; with one, the later packets' draws (and so
    the others' decisions) are another realisation."""
    models: list[LossModel] = [m for m in (range_model,) if m is not None]
    if loss > 0:
        models.append(_builtin(Bernoulli, p=loss))
    if burst is not None and burst.mean_loss > 0:
        if burst.mean_duration is not None:
            models.append(_builtin(GilbertElliottTime, mean_loss=burst.mean_loss, mean_duration=burst.mean_duration))
        else:
            models.append(_builtin(GilbertElliott, mean_loss=burst.mean_loss, mean_burst=burst.mean_burst or 1.0))
    if named is not None:
        models.append(named)
    return _builtin(Composite, models=tuple(models)) if models else None


def _own_loss(link: LinkSection, c: CommsSection, ranged: LossModel | None, named: LossModel | None) -> LossModel:
    """A [[comms.links]] entry's models as the channel takes them: its loss and burst where given, whatever their
    value (a loss of 0 too: only a key left out takes [comms]'s), and no model at all as an empty Composite, which
    loses nothing. None would tell the channel "not given": a link's loss 0 lost the fleet's 5 %."""
    model = _loss_model(ranged, *link.losses(c.loss, c.burst), named)
    return _builtin(Composite, models=()) if model is None else model


def named_loss_model(scenario: Scenario) -> LossModel | None:
    """The loss model comms.loss_model names, with its options; None if it names none."""
    c = scenario.comms
    if c.loss_model is None:
        return None
    model: LossModel = extension("loss", c.loss_model, c.loss_model_options)
    return model


def channel_params(scenario: Scenario, with_named: bool = True) -> ChannelParams:
    """The channel the scenario describes; ValueError (from the models) for inconsistent numbers. with_named: False
    leaves comms.loss_model out (the checks of the scenario's own keys: the named model has its own,
    supervisor.config.extension_checks)."""
    c = scenario.comms
    radio_modem = modem_params(scenario)
    ranged, named = range_model(scenario, radio_modem), named_loss_model(scenario) if with_named else None
    links = {
        (link.sender, link.receiver): LinkParams(_own_loss(link, c, ranged, named), link.extra_delay)
        for link in c.links
    }
    capture = (
        Capture(ranged, c.capture_threshold) if c.reception == "sinr" and isinstance(ranged, LinkBudgetRange) else None
    )
    return ChannelParams(
        sound_speed(scenario), radio_modem, c.packet_bytes, c.jitter, _loss_model(ranged, c.loss, c.burst, named),
        links, capture,
    )  # fmt: skip


def predictor_of(scenario: Scenario) -> Predictor:
    co = scenario.coordination
    predictor: Predictor = extension("predictor", co.predictor, co.predictor_options)
    return predictor


def current_observer_of(scenario: Scenario) -> CurrentObserver | None:
    """The on-board current observer (vehicles.current_observer) with the gains of the path-following loop it feeds:
    on where the scenario says, or by default ("auto") where there is a current the controllers are not told."""
    env, pf = scenario.environment, scenario.path_following
    wanted = {"on": True, "off": False}.get(env.estimate_current, not env.still and not env.current_known)
    return CurrentObserver.for_loop(pf.k1, pf.delta, pf.k2) if wanted else None


def controller_of(
    scenario: Scenario, vehicle_id: int, actuators: Actuators | None = None
) -> PathFollowingController:  # fmt: skip
    """vehicle_id's path-following controller with its options (supervisor.config.controller_choice); a controller
    with a field `fin_moment` that its options leave out gets the fins' largest moment per (m/s)^2
    (vehicles.actuators)."""
    context = None if actuators is None else {"fin_moment": actuators.fin_moment}
    name = controller_name(scenario, vehicle_id)
    controller: PathFollowingController = extension("controller", name, controller_options(scenario, name), context)
    return controller


def transmission_options(scenario: Scenario) -> dict[str, Any]:
    """The transmission policy's options: the built-ins' from their keys of [comms.transmit], an extension's from
    its `options` table."""
    tx = scenario.comms.transmit
    if tx.policy == "periodic":
        return {"period": tx.period}
    if tx.policy == "event":
        keys = ("threshold", "threshold_decay", "decay_rate", "min_interval", "heartbeat")
        return {key: getattr(tx, key) for key in keys}
    return dict(tx.options)


def radio(scenario: Scenario, vehicle_id: int) -> Radio:
    """How a vehicle decides to transmit: its policy gets the fleet's predictor and v_r if it has such fields."""
    tx, co = scenario.comms.transmit, scenario.coordination
    context = {"predictor": predictor_of(scenario), "v_r": co.v_r}
    policy: Policy = extension("transmission", tx.policy, transmission_options(scenario), context)
    return Radio(policy, tdma_schedule(scenario))


def broker_core(scenario: Scenario, seed: int) -> BrokerCore:
    neighbours = {i: scenario.neighbours(i) for i in scenario.vehicle_ids}
    wide = wide_for(scenario.vehicle_ids)
    return BrokerCore(Channel(channel_params(scenario), seed), neighbours, link_stats(scenario), wide=wide)


# A delivery keeps its pair in the delivered graph for this many transmit intervals: more than one, so that the
# spread of delays (jitter, time of flight) does not let a link that delivers every interval drop out; less than two,
# so that a single lost packet shows.
HORIZON_INTERVALS = 1.5


def link_stats(scenario: Scenario) -> LinkStats:
    """The link books the broker and the supervisor keep: snapshots every stats window, lambda_2 of the delivered
    graph over delivered_graph_horizon."""
    return LinkStats(scenario.vehicle_ids, scenario.comms.stats_window, delivered_graph_horizon(scenario))


def delivered_graph_horizon(scenario: Scenario) -> float:
    """s a delivery keeps its pair in the delivered graph (lambda_2): the stats window, or HORIZON_INTERVALS times the
    longest interval a vehicle's schedule leaves between transmissions if that is longer. Without one (the event
    policy without a heartbeat, a user's policy), the shortest its slots allow: with TDMA a frame, whatever the
    policy (a 10 s window on 24 s frames read a third of the windows as disconnected, every link delivering every
    frame)."""
    interval = transmit_interval(scenario)
    shortest = held_to_frames(scenario, scenario.scenario.step)  # one frame with TDMA, a step without
    longest = shortest if interval is None else interval  # held to frames already: a frame or a step at least
    return max(scenario.comms.stats_window, HORIZON_INTERVALS * longest)


def transmit_interval(scenario: Scenario) -> float | None:
    """The longest time [s] a vehicle's schedule leaves between two of its transmissions: its period (every step
    without one), or the heartbeat of the event policy, held until its next TDMA slot (links.held_to_frames). None
    for the event policy without a heartbeat: a vehicle may then rightly stay quiet for as long as its gamma is
    predictable."""
    tx = scenario.comms.transmit
    interval = (tx.period or scenario.scenario.step) if tx.policy == "periodic" else tx.heartbeat
    return None if interval is None else held_to_frames(scenario, interval)


def restore_state(config: VehicleConfig, message: Message) -> VehicleState:
    """A vehicle as its last recorded state message describes it: where a restarted process picks up. ValueError if
    the message is not a state report of this vehicle."""
    report = StateReport.from_message(message, config.vehicle_id)
    position, velocity = np.array(report.position, dtype=float), np.array(report.velocity, dtype=float)
    angular = np.array(report.angular_velocity, dtype=float)
    rotation = np.array(report.rotation, dtype=float).reshape(3, 3)
    if config.model.dim == 3:
        x = SPATIAL.pack(position, rotation, velocity, angular)
    else:
        x = PLANAR.pack(position[:2], rotation[:2, :2], velocity[:2], angular[2:])
    return VehicleState(report.t, config.model.normalize(x), float(report.gamma), float(report.gamma_dot))


def restarted_node(
    config: VehicleConfig, last_state: Message, seq: int, step: int, dt: float, faults: Sequence[FaultSpec]
) -> NodeState:
    """A vehicle process restarted at sync step `step`: its vehicle coasted without inputs from its last recorded
    state to then, and the controller started at the path point nearest to where it is (vehicles.coast); its
    transmission count and its stuck gamma sensor's reading (the scenario's faults say whether it is still stuck),
    and nothing else (no neighbour estimates, no transmission-policy memory; its navigation filter starts again as at
    the run's start, around where the vehicle is: its old estimate is of a place the vehicle has left). Every engine
    and `cpf resim` restart a vehicle this way."""
    last = restore_state(config, last_state)
    report = StateReport.from_message(last_state, config.vehicle_id)
    return NodeState(resumed(config, last, step - report.k, dt), seq, frozen=_still_stuck(report, faults, step, dt))


def _still_stuck(report: StateReport, faults: Sequence[FaultSpec], step: int, dt: float) -> NeighbourEstimate | None:
    """The reading a gamma sensor stuck at (frozen_gamma) holds at a restart at `step`: the last state's, if the
    stuck run that state was in (supervisor.config.derived.stuck_spans) still holds then; None otherwise (a sensor
    that sticks anew sticks at the restarted vehicle's gamma). The sensor's, not the process's: it survives."""
    if report.frozen is None:
        return None
    for first, end in stuck_spans(faults, report.vehicle, dt):
        if first <= report.k and first <= step and (end is None or step < end):
            return NeighbourEstimate(report.frozen[0], report.frozen[1], first * dt)
    return None

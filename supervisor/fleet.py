"""From a validated Scenario to what each vehicle runs: its VehicleConfig and its initial VehicleState.

Used by both engines (and by a vehicle process, which builds only its own), so vehicles start identically.
"""

from __future__ import annotations

import math

import numpy as np

from comms.channel import ChannelParams
from supervisor.scenario_schema import (
    CirclePath,
    HelixPath,
    LawnmowerPath,
    LinePath,
    PathSpec,
    Scenario,
    VehicleSection,
)
from vehicles.agent import VehicleConfig, VehicleState
from vehicles.coordination import CoordinationGains
from vehicles.dynamics import PLANAR, SPATIAL, Model
from vehicles.geometry import rotation_2d, rotation_from_rpy
from vehicles.path_following import PathFollowingGains
from vehicles.paths import Circle, Helix, Lawnmower, Line, Path, closest_gamma
from vehicles.transmission import PeriodicPolicy

# How far along a path the initial-gamma search looks, in units of gamma, either side of zero.
CLOSEST_SEARCH_SPAN = 1000.0


def build_path(spec: PathSpec) -> Path:
    if isinstance(spec, HelixPath):
        return Helix(spec.radius, spec.climb, spec.period, spec.phase, spec.center)
    if isinstance(spec, CirclePath):
        return Circle(spec.radius, spec.period, spec.phase, spec.center)
    if isinstance(spec, LinePath):
        return Line(spec.start, spec.velocity)
    assert isinstance(spec, LawnmowerPath)
    return Lawnmower(spec.origin, spec.leg_length, spec.spacing, spec.legs, spec.heading, spec.scale)


def model_of(scenario: Scenario) -> Model:
    return SPATIAL if scenario.scenario.dimension == 3 else PLANAR


def vehicle_config(scenario: Scenario, vehicle_id: int) -> VehicleConfig:
    section = _section(scenario, vehicle_id)
    pf, co = scenario.path_following, scenario.coordination
    return VehicleConfig(
        vehicle_id=vehicle_id,
        model=model_of(scenario),
        params=scenario.vehicle_params(),
        path=build_path(section.path),
        path_following=PathFollowingGains(pf.delta, pf.k1, pf.k2, pf.k_zeta),
        coordination=CoordinationGains(co.k, co.k2, co.v_r, co.law),
        predictor=co.predictor,
    )


def initial_state(scenario: Scenario, config: VehicleConfig) -> VehicleState:
    """The vehicle at rest (or as given) at t = 0, gamma0 at the nearest path point unless given."""
    section = _section(scenario, config.vehicle_id)
    roll, pitch, yaw = (math.radians(a) for a in section.attitude_rpy_deg)
    position = np.array(section.position, dtype=float)
    if config.model.dim == 3:
        rot = rotation_from_rpy(roll, pitch, yaw)
        x = SPATIAL.pack(position, rot, np.array(section.velocity), np.array(section.angular_velocity))
    else:
        rot = rotation_2d(yaw)
        x = PLANAR.pack(position[:2], rot, np.array(section.velocity[:2]), np.array(section.angular_velocity[2:]))
    if section.gamma0 == "closest":
        target = position if config.model.dim == 3 else np.array([*position[:2], _path_height(config.path)])
        gamma0 = closest_gamma(config.path, target, -CLOSEST_SEARCH_SPAN, CLOSEST_SEARCH_SPAN)
    else:
        gamma0 = float(section.gamma0)
    return VehicleState(t=0.0, x=x, gamma=gamma0, gamma_dot=0.0)


def _path_height(path: Path) -> float:
    """A planar vehicle ignores z: measure its distance to the path in the path's own plane."""
    return float(path.evaluate(0.0)[0][2])


def _section(scenario: Scenario, vehicle_id: int) -> VehicleSection:
    return next(v for v in scenario.vehicles if v.id == vehicle_id)


def channel_params(scenario: Scenario) -> ChannelParams:
    c = scenario.comms
    return ChannelParams(c.sound_speed, c.bitrate, c.packet_bytes, c.jitter, c.loss)


def transmit_policy(scenario: Scenario) -> PeriodicPolicy:
    return PeriodicPolicy(scenario.comms.tx_period)

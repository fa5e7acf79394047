"""Each vehicle's plausibility bounds (comms.records.plausible.Plausible), from the scenario, in this one place; the
supervisor's intake and the broker drop a state beyond them as the vehicle's fault (docs/plausibility.md).

From physics, generous: the speed bound is SPEED_MARGIN times the vehicle's own top speed (its preset's full thrust
against its surge damping; MAX_SPEED where its model has none), or its initial speed if more; over ground, the
current's strongest on top; gamma_dot at most GAMMA_DOT_MARGIN times what that speed gives along the slowest stretch
of its path (|p_d'(gamma)| there), plus the coordination's reference rate. No legitimate run comes near them (every
config in configs/, both engines: tests/test_plausibility.py); a vehicle that sends 1e30 is far beyond.
"""

from __future__ import annotations

import math

import numpy as np

from comms.records.fields import MAX_SPEED
from comms.records.plausible import Lie, Plausible
from supervisor.config.derived import steps_of_fault, stuck_spans
from supervisor.config.fault_schema import GammaOffsetFault
from supervisor.config.fleet import build_path
from supervisor.config.plant import current_of
from supervisor.config.presets_table import top_speed
from supervisor.config.scenario_schema import Scenario
from supervisor.config.vehicle_models import params_of
from vehicles.paths import Path

SPEED_MARGIN = 2.0  # x the vehicle's top speed
GAMMA_DOT_MARGIN = 10.0  # x the fastest rate its speed allows along its path
SAMPLES = 512  # gammas at which a path's |p_d'| is looked at


def plausibility(sc: Scenario) -> dict[int, Plausible]:
    """vehicle id -> its bounds."""
    current = _current_speed(sc)
    return {vid: _bounds(sc, vid, current) for vid in sc.vehicle_ids}


def _bounds(sc: Scenario, vid: int, current: float) -> Plausible:
    top = top_speed(params_of(sc, vid))
    section = next(v for v in sc.vehicles if v.id == vid)
    speed = min(SPEED_MARGIN * top, MAX_SPEED) if math.isfinite(top) else MAX_SPEED
    speed = max(speed, math.hypot(*section.velocity))  # a start faster than that (the schema allows 8.7 m/s) slows
    slowest = _slowest(build_path(section.path))
    rate = GAMMA_DOT_MARGIN * (speed + current) / slowest + abs(sc.coordination.v_r)
    return Plausible(speed, speed + current, rate, _lies(sc, vid, rate))


def _lies(sc: Scenario, vid: int, rate: float) -> tuple[Lie, ...]:
    """When and how far the scenario's faults make vehicle vid transmit a gamma other than its own, on the steps
    each acts on (supervisor.config.derived: from half a step before its start): a gamma_offset fault's offset, and
    while its gamma sensor is stuck (its frozen_gamma faults that meet as one), what its gamma may have moved (at
    rate) since the reading stuck. A lie the scenario asks for is data, not a fault of the vehicle's process: the
    Zenoh engine must carry it as the in-process engine does; the same lie at another time is not the scenario's."""
    dt = sc.scenario.step
    mine = [f for f in sc.faults if isinstance(f, GammaOffsetFault) and f.vehicle == vid]
    offsets = [Lie(*steps_of_fault(f, dt), offset=abs(f.offset)) for f in mine]
    return (*offsets, *(Lie(first, end, drift=rate) for first, end in stuck_spans(sc.faults, vid, dt)))


def _slowest(path: Path) -> float:
    """The smallest |p_d'(gamma)| over a period of the path, or over its curved stretch and a little beyond (a
    straight one's is its speed); a floor of 1e-3 m per unit of gamma."""
    period, straight = path.gamma_period, path.straight_beyond
    lo, hi = (0.0, period) if period is not None else straight if straight is not None else (0.0, 1.0)
    gammas = np.linspace(lo - 1.0, hi + 1.0, SAMPLES)
    return max(1e-3, min(math.hypot(*path.evaluate_floats(float(g))[1]) for g in gammas))


def _current_speed(sc: Scenario) -> float:
    """The strongest current over the run at any depth the fleet starts at (0 in still water), with its shear."""
    current = current_of(sc)
    if current is None:
        return 0.0
    depths = {float(v.position[2]) for v in sc.vehicles} | {0.0}
    times = np.linspace(0.0, sc.scenario.duration, 64)
    strongest = max(math.hypot(*current.velocity(float(t), z)) for t in times for z in depths)
    return 2.0 * strongest + 1.0  # a vehicle may dive and meet a stronger one: generous

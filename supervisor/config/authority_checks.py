"""Paths a vehicle's fins cannot hold it on, said as warnings by `cpf validate` and `cpf run`.

On fins (a moment that grows with the square of the speed: vehicles.actuators) a vehicle that is not neutrally
buoyant needs a pitch moment to fly a line at all, and below some speed it needs more than its fins give
(vehicles.trim). Each vehicle's plant (its drawn one under [vehicle] uncertainty: the same draw the run makes) is
trimmed at its path's speed and climb, v_r |p_d'(gamma)| along the tangent, at SAMPLES gammas over the run; where the
moment exceeds the fins', the warning names the vehicle, what it needs and the least speed, up to the vehicle's top
speed, at which it would hold. A 3-D run with fins only; the trim leaves out turns and the current.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from numerics import asin
from supervisor.config.fleet import build_path
from supervisor.config.plant import actuators_of, plant_of
from supervisor.config.presets_table import top_speed
from supervisor.config.scenario_schema import Scenario
from supervisor.config.vehicle_models import params_of, vehicle_of
from vehicles.params import VehicleParams
from vehicles.paths import Path
from vehicles.trim import pitch_moment
from vehicles.vehicle_model import VehicleModel

SAMPLES = 16  # gammas along the run at which each path is trimmed
_FASTER = 0.05  # m/s: the step of the search for the least speed that holds
_TRIMS: dict[tuple[object, VehicleParams, float, float], float | None] = {}  # _moment's (models compare by value)
_KEPT = 4096  # trims _TRIMS holds at most
_FASTEST = 10.0  # m/s: where that search gives up for a vehicle with no top speed


def authority_warnings(sc: Scenario) -> list[str]:
    return [_said(sc, vid, need) for vid, need in unheld(sc).items()]


def unheld(sc: Scenario) -> dict[int, Need]:
    """The vehicles whose fins cannot hold them on their paths: id -> the worst point's need."""
    if sc.scenario.dimension != 3:
        return {}
    out = {}
    for vid in sc.vehicle_ids:
        need = _worst(sc, vid)
        if need is not None and need.moment > need.fins:
            out[vid] = need
    return out


@dataclass(frozen=True, slots=True)
class Need:
    """What a vehicle's trim needs at the point of its path where its fins are shortest of it."""

    moment: float  # N m, the pitch moment the trim needs (its size)
    fins: float  # N m, what the fins give there
    speed: float  # m/s
    climb: float  # rad
    least_speed: float | None  # m/s: the least speed, up to its top speed, at which they hold it (None: none)
    drawn: bool  # the plant is the vehicle's drawn one (vehicle.uncertainty)


def _worst(sc: Scenario, vid: int) -> Need | None:
    nominal = params_of(sc, vid)
    fins = actuators_of(sc, nominal)
    if fins is None:
        return None
    plant = plant_of(sc, vid) or nominal
    model = vehicle_of(sc, vid)
    try:
        ratio, fin, speed, climb, moment = max(_needs(sc, vid, model, plant, fins.fin_moment), key=lambda n: n[0])
        least = None if ratio <= 1.0 else _least_speed(model, plant, fins.fin_moment, speed, climb, top_speed(plant))
    except (ValueError, ArithmeticError, TypeError, RuntimeError):  # someone else's model: the run reports it
        return None
    return Need(abs(moment), fin, speed, climb, least, plant is not nominal)


def _said(sc: Scenario, vid: int, need: Need) -> str:
    drawn = " (its plant as drawn: vehicle.uncertainty)" if need.drawn else ""
    least = need.least_speed
    faster = f"it holds from {least:.2f} m/s" if least is not None else "no speed up to its top speed holds it"
    return (
        f"coordination.v_r: vehicle {vid}{drawn} needs a pitch moment of {need.moment:.2f} N m to fly its path at "
        f"{need.speed:.2f} m/s (climbing {math.degrees(need.climb):.0f} deg) and its fins give {need.fins:.2f} N m "
        f"there, so it will leave its path ({faster}; vehicles/trim.py), got {sc.coordination.v_r:g}"
    )


def _needs(
    sc: Scenario, vid: int, model: VehicleModel, plant: VehicleParams, fin_moment: float
) -> Iterator[tuple[float, float, float, float, float]]:  # fmt: skip
    """(moment needed / fins' moment, fins' moment, speed, climb, moment) at the sampled points of vid's path."""
    section = next(v for v in sc.vehicles if v.id == vid)
    path, v_r = build_path(section.path), sc.coordination.v_r
    for gamma in _gammas(path, section.gamma0, v_r * sc.scenario.duration):
        tangent = path.evaluate_floats(float(gamma))[1]
        norm = math.sqrt(sum(x * x for x in tangent))
        speed = abs(v_r) * norm
        if speed <= 0.0:
            continue
        climb = asin(max(-1.0, min(1.0, math.copysign(tangent[2], v_r) / norm)))
        moment = _moment(model, plant, speed, climb)
        fin = min(plant.max_torque, fin_moment * speed * speed)
        if moment is not None:
            yield abs(moment) / max(fin, 1e-12), fin, speed, climb, moment


def _gammas(path: Path, gamma0: float | str, run: float) -> Sequence[float]:
    """Where a path is trimmed: over a period of a periodic one, else over the run from its gamma0 (0 for "closest":
    the nearest point's search costs more than the check, and a path that is not periodic is straight or nearly
    so near its start)."""
    period = path.gamma_period
    if period is not None:
        return [float(g) for g in np.linspace(0.0, period, SAMPLES)]
    start = gamma0 if isinstance(gamma0, float | int) else 0.0
    return [float(g) for g in np.linspace(start, start + run, SAMPLES)]


def _moment(model: VehicleModel, plant: VehicleParams, speed: float, climb: float) -> float | None:
    """pitch_moment, once per fleet: vehicles of one model and plant on parallel paths need the same trim."""
    key = (model, plant, speed, climb)
    try:
        known = key in _TRIMS
    except TypeError:  # someone else's model that does not hash
        return pitch_moment(model, plant, speed, climb)
    if not known:
        if len(_TRIMS) >= _KEPT:  # a long sweep in one process: start again rather than grow
            _TRIMS.clear()
        _TRIMS[key] = pitch_moment(model, plant, speed, climb)
    return _TRIMS[key]


def _least_speed(
    model: VehicleModel, plant: VehicleParams, fin_moment: float, speed: float, climb: float, top: float
) -> float | None:  # fmt: skip
    """The least speed above `speed`, in steps of _FASTER up to top, whose trim the fins hold."""
    for k in range(1, int((min(top, _FASTEST) - speed) / _FASTER) + 1):
        u = speed + k * _FASTER
        moment = _moment(model, plant, u, climb)
        if moment is not None and abs(moment) <= min(plant.max_torque, fin_moment * u * u):
            return u
    return None

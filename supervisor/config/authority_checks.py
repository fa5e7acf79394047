"""Paths a vehicle's fins cannot hold it on, said as warnings by `cpf validate` and `cpf run`.

On fins (a moment that grows with the square of the speed: vehicles.actuators) a vehicle that is not neutrally
buoyant needs a pitch moment to fly a line at all, and below some speed it needs more than its fins give
(vehicles.trim). Each vehicle's plant (its drawn one under [vehicle] uncertainty: the same draw the run makes) is
trimmed at its path's speed and climb, v_r |p_d'(gamma)| along the tangent, at SAMPLES gammas over the run; where the
moment exceeds the fins', the warning names the vehicle, what it needs and the least speed, up to the vehicle's top
speed, at which it would hold. A 3-D run with fins only; the trim leaves out turns and the current. In any run,
a vehicle asked for more speed through the water (its path's less the current's) than its top speed is warned of.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from numerics import asin
from supervisor.config.fleet import build_path
from supervisor.config.memo import Memo
from supervisor.config.plant import actuators_of, current_of, plant_of
from supervisor.config.presets_table import top_speed
from supervisor.config.scenario_schema import Scenario, VehicleSection
from supervisor.config.vehicle_models import params_of, vehicle_of
from vehicles.actuators import Actuators
from vehicles.current import Current
from vehicles.geometry import Float3
from vehicles.params import VehicleParams
from vehicles.paths import Path
from vehicles.saturation import clamp
from vehicles.trim import trim
from vehicles.vehicle_model import VehicleModel

SAMPLES = 16  # gammas along the run at which each path is trimmed
_FASTER = 0.05  # m/s: the step of the search for the least speed that holds
Float2 = tuple[float, float]
Speeds = tuple[float, float, Float3]  # m/s through the water, m/s along the path, the current there
_TRIMS: Memo[Float2] = Memo()  # _held's (models compare by value)
_FASTEST = 10.0  # m/s: where that search gives up for a vehicle with no top speed


def authority_warnings(sc: Scenario) -> list[str]:
    return [_said(sc, vid, need) for vid, need in unheld(sc).items()] + _too_fast(sc)


def _too_fast(sc: Scenario) -> list[str]:
    """A vehicle asked to go faster through the water than its top speed (full thrust against its surge damping)
    falls behind its gamma, and the fleet with it: ~13 m/s of a REMUS 100 (2.5 m/s) passed unsaid (a new user), and
    so did a head current of 2 m/s on lines flown at 1 m/s (the fleet crawled at 0.47 v_r). Any dimension, fins or
    not; a model of someone else's that cannot say is left out."""
    current, out = current_of(sc), []
    for section in sc.vehicles:
        try:
            top = top_speed(plant_of(sc, section.id) or params_of(sc, section.id))
        except (ValueError, ArithmeticError, TypeError, AttributeError):
            continue
        speeds = list(_through_water(sc, section, current))
        needed, _, water = max(speeds)
        if needed > top:
            by_current = current is not None and max(along for _, along, _ in speeds) <= top
            out.append(_said_fast(sc, section.id, (needed, top), by_current, water))
    return out


def _through_water(sc: Scenario, section: VehicleSection, current: Current | None) -> Iterator[Speeds]:
    """(speed through the water, speed along the path, the current there) at the path's sampled points
    (sample_gammas): the path's velocity v_r p_d'(gamma) less the current at its depth, at the time the vehicle first
    reaches it going at v_r from its gamma0 (within the run)."""
    path, v_r, duration = build_path(section.path), sc.coordination.v_r, sc.scenario.duration
    start = float(section.gamma0) if isinstance(section.gamma0, float | int) else 0.0
    period = path.gamma_period
    for gamma in sample_gammas(path, section.gamma0, v_r * duration):
        position, tangent, _ = path.evaluate_floats(gamma)
        velocity = [v_r * x for x in tangent]
        t = (gamma - start) / v_r if v_r else 0.0
        t = min(t % (period / abs(v_r)) if period is not None and v_r else max(t, 0.0), duration)
        water = (0.0, 0.0, 0.0) if current is None else current.velocity(t, position[2])
        yield math.hypot(*(v - c for v, c in zip(velocity, water, strict=True))), math.hypot(*velocity), water


def _said_fast(sc: Scenario, vid: int, speeds: Float2, by_current: bool, water: Float3) -> str:
    """The warning: the current's doing where the path alone is within the top speed, else v_r's."""
    (needed, top), current = speeds, "[" + ", ".join(f"{c:g}" for c in water) + "]"
    field, got = ("environment.current", list(sc.environment.current)) if by_current else ("coordination.v_r", None)
    what = (
        f"needs up to {needed:.3g} m/s through the water (its path less the current of {current} m/s there)"
        if any(water)
        else f"is asked for up to {needed:.3g} m/s along its path"
    )
    return (
        f"{field}: vehicle {vid} {what}, above its top speed of {top:.3g} m/s (cpf presets): it will fall behind, "
        f"got {sc.coordination.v_r if got is None else got}"
    )


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
    norm: float  # |p_d'| there, m per unit of gamma: the least speed is least_speed / norm in v_r
    drawn: bool  # the plant is the vehicle's drawn one (vehicle.uncertainty)


def _worst(sc: Scenario, vid: int) -> Need | None:
    model = vehicle_of(sc, vid)
    nominal = model.parameters()
    fins = actuators_of(sc, vid, nominal)
    if fins is None:
        return None
    plant = plant_of(sc, vid) or nominal
    try:
        needs = list(_needs(sc, vid, model, plant, fins))
        if not needs:
            return None
        moment, fin, speed, climb, norm = max(needs, key=lambda n: n[0] / max(n[1], 1e-12))
        least = None
        if moment > fin:
            least = _least_speed(model, plant, fins, speed, climb, top_speed(plant))
    except (ValueError, ArithmeticError, TypeError, RuntimeError):  # someone else's model: the run reports it
        return None
    return Need(moment, fin, speed, climb, least, norm, plant is not nominal)


def _said(sc: Scenario, vid: int, need: Need) -> str:
    drawn = " (its plant as drawn: vehicle.uncertainty)" if need.drawn else ""
    least = need.least_speed
    faster = (
        f"it holds from {least:.2f} m/s, v_r {least / need.norm:.3g}"
        if least is not None
        else "no speed up to its top speed holds it"
    )
    what = (
        f"needs a pitch moment of {need.moment:.2f} N m"
        if math.isfinite(need.moment)
        else "finds no trim within 45 deg of attack"
    )
    degrees = round(math.degrees(need.climb))
    slope = "level" if degrees == 0 else f"climbing {degrees} deg" if degrees > 0 else f"descending {-degrees} deg"
    return (
        f"coordination.v_r: vehicle {vid}{drawn} {what} to fly its path at {need.speed:.2f} m/s ({slope}) and its "
        f"fins give {need.fins:.2f} N m there, so it will leave its path ({faster}; vehicles/trim.py), got "
        f"{sc.coordination.v_r:g}"
    )


def _needs(
    sc: Scenario, vid: int, model: VehicleModel, plant: VehicleParams, fins: Actuators
) -> Iterator[tuple[float, float, float, float, float]]:  # fmt: skip
    """(moment needed [N m] (inf: no trim), the fins' moment at the trim's surge speed, speed along the path,
    climb, |p_d'|) at the sampled points of vid's path."""
    section = next(v for v in sc.vehicles if v.id == vid)
    path, v_r = build_path(section.path), sc.coordination.v_r
    for gamma in sample_gammas(path, section.gamma0, v_r * sc.scenario.duration):
        tangent = path.evaluate_floats(float(gamma))[1]
        norm = math.sqrt(sum(x * x for x in tangent))
        if norm <= 0.0:
            continue
        speed = abs(v_r) * norm  # v_r = 0 too: a vehicle asked to stop on its path (no trim then, as at 1e-6 m/s)
        climb = asin(clamp(math.copysign(1.0, v_r) * tangent[2] / norm, -1.0, 1.0))  # the way it is flown
        yield (*_held(model, plant, fins, speed, climb), speed, climb, norm)


def sample_gammas(path: Path, gamma0: float | str, run: float, samples: int = SAMPLES) -> Sequence[float]:
    """Where a path is trimmed: over a period of a periodic one, else over the run (gamma's change, signed) from its
    gamma0 (0 for "closest": the nearest point's search costs more than the check, and a path that is not periodic
    is straight or nearly so near its start)."""
    period = path.gamma_period
    start = gamma0 if isinstance(gamma0, float | int) else 0.0
    first, last = (0.0, period) if period is not None else (start, start + run)
    return [float(g) for g in np.linspace(first, last, samples)]


def _held(model: VehicleModel, plant: VehicleParams, fins: Actuators, speed: float, climb: float) -> Float2:
    """(the pitch moment the trim needs [N m], inf if there is none; the fins' moment at its surge speed [N m]),
    once per fleet: vehicles of one model and plant on parallel paths need the same trim."""
    return _TRIMS.get((model, plant, fins, speed, climb), lambda: _trimmed(model, plant, fins, speed, climb))


def _trimmed(model: VehicleModel, plant: VehicleParams, fins: Actuators, speed: float, climb: float) -> Float2:
    """(the trim's moment, inf if none; the fins' moment at its surge speed, within the vehicle's torque limit)."""
    found = trim(model, plant, speed, climb)
    if found is None:
        return math.inf, min(plant.max_torque, fins.torque_limit(speed))
    return abs(found.moment), min(plant.max_torque, fins.torque_limit(found.surge))


def _least_speed(
    model: VehicleModel, plant: VehicleParams, fins: Actuators, speed: float, climb: float, top: float
) -> float | None:  # fmt: skip
    """The least speed above `speed`, in steps of _FASTER up to top, whose trim the fins hold."""
    for k in range(1, int((min(top, _FASTEST) - speed) / _FASTER) + 1):
        u = speed + k * _FASTER
        moment, held = _held(model, plant, fins, u, climb)
        if moment <= held:
            return u
    return None

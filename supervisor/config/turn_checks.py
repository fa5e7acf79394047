"""Paths that turn tighter than a vehicle can, said as warnings by `cpf validate` and `cpf run`.

Flying its path at v_r, a vehicle's heading must turn as the path's tangent does: at the yaw rate v_r psi'(gamma),
psi' the horizontal course's turn per unit of gamma, at the speed v_r |p_d'(gamma)|. A steady turn at that rate
takes a yaw moment (vehicles.turn: the yaw damping, the Munk moment and the lift's at the drift angle where the sway
balances), and the rudder gives at most the vehicle's max_torque (on fins, what they give at the turn's surge, within
it). Where the turn needs more, the vehicle flies a wider circle than its path, whatever its controller: on the
remus100 at 1.5 m/s the least radius is 3.04 m, and a circle of 2 m is flown 1.65 m off its path
(tests/test_turn.py). Each vehicle is judged where its path turns fastest along the stretch its run flies (_turns:
sampled, and densely where the tangent turns between two samples more than their rates explain, as at a lawnmower's
turns), from the vehicle's gamma0 and at its top speed if [saturation] holds it. Where the rudder holds the turn, a
controller that bounds its own rates says so (its optional turn_rate_bound, docs/extending.md): line_of_sight, the
default on fins, keeps within half of what the fins give, so it turns no tighter than 9.89 m at 1 m/s where the
rudder holds 6.3 m (a new user's 7 m circles flew 7 m off, unwarned; tests/test_turn.py holds it both sides). The
thrust a turn takes is judged too (the slip drags: remus100_neutral needs 15.5 N of its 14.1 on a 3.5 m circle at
1.5 m/s and slows down). The turn is taken at the path's speed (the vehicle, |delta| behind its point, flies a little
faster and wider). Left out: the current, a climb, the controller's transient; a model of someone else's that cannot
say is left out too.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import numpy as np

from numerics import atan2
from supervisor.config.authority_checks import sample_gammas
from supervisor.config.controller_choice import controller_name
from supervisor.config.fleet import build_path, controller_of, initial_gamma
from supervisor.config.memo import Memo
from supervisor.config.plant import actuators_of, plant_of
from supervisor.config.scenario_schema import Scenario, VehicleSection
from supervisor.config.vehicle_models import top_speed_of, vehicle_of
from vehicles.actuators import Actuators
from vehicles.params import VehicleParams
from vehicles.paths import Path
from vehicles.trim import bisected
from vehicles.turn import Turn, fastest_turn, turn
from vehicles.vehicle_model import VehicleModel


def turn_warnings(sc: Scenario) -> list[str]:
    out = []
    for index, section in enumerate(sc.vehicles):
        try:
            said = _too_tight(sc, index, section)
        except (ValueError, ArithmeticError, TypeError, AttributeError, RuntimeError):  # someone else's model or path
            continue
        if said is not None:
            out.append(said)
    return out


def _too_tight(sc: Scenario, index: int, section: VehicleSection) -> str | None:
    """The warning for one vehicle whose path turns faster than its yaw moment can turn it (None: it can)."""
    speed, rate, level = max(_turns(sc, section), key=lambda turning: (turning[1], turning[0]), default=(0, 0, 0))
    if rate <= 0.0:
        return None
    model = vehicle_of(sc, section.id)
    nominal = model.parameters()
    plant = plant_of(sc, section.id) or nominal
    fins = actuators_of(sc, section.id, nominal)
    found, (has, thrust), widest = _judged(model, plant, (fins, nominal.max_surge_force), speed, rate)
    if found is not None and abs(found.moment) <= has and found.thrust <= thrust:  # does the controller ask for it?
        return _bounded(sc, index, section, (model, nominal, fins), (speed, rate, level))
    source = "its max_torque" if fins is None else "its fins there, within max_torque"
    needs = (
        ["a drift past 45 deg"] if found is None else
        [f"a yaw moment of {abs(found.moment):.3g} N m ({source} gives {has:.3g})"] * (abs(found.moment) > has)
        + [f"a thrust of {found.thrust:.3g} N (it has {thrust:.3g}: it slows down)"] * (found.thrust > thrust)
    )  # fmt: skip
    drawn = " (its plant as drawn: vehicle.uncertainty)" if plant is not nominal else ""
    return (
        f"vehicles[{index}].path: vehicle {section.id}{drawn} must turn at {rate:.3g} rad/s to follow it at "
        f"{speed:.3g} m/s (v_r {sc.coordination.v_r:g}) and that takes {' and '.join(needs)}, so it turns no tighter "
        f"than a radius of {widest * level / speed:.3g} m at that speed: it will fly wide of its path "
        f"(vehicles/turn.py), got a turn of radius {level / rate:.3g} m"
    )


def _bounded(
    sc: Scenario, index: int, section: VehicleSection, vehicle: tuple[VehicleModel, VehicleParams, Actuators | None],
    turning: tuple[float, float, float],
) -> str | None:  # fmt: skip
    """The warning for a vehicle whose controller bounds its rate below the turn (its optional turn_rate_bound:
    line_of_sight keeps within a share of its fins), at the turn its own model predicts; None: it asks for it."""
    (model, nominal, fins), (speed, rate, level) = vehicle, turning
    bound = getattr(controller_of(sc, section.id, fins), "turn_rate_bound", None)
    if not callable(bound):
        return None

    def asks(r: float) -> float:  # 1 where the controller asks for the rate r of a steady turn, else -1
        found = turn(model, nominal, speed, r)
        return 1.0 if found is not None and bound(nominal, found.surge, r, found.moment) >= r else -1.0

    if asks(rate) > 0 or asks(0.0) < 0:
        return None
    fastest = bisected(asks, 0.0, rate, 1.0, _HALVINGS)
    return (
        f"vehicles[{index}].path: vehicle {section.id} must turn at {rate:.3g} rad/s to follow it at {speed:.3g} m/s "
        f"(v_r {sc.coordination.v_r:g}); its controller {controller_name(sc, section.id)} asks for at most "
        f"{fastest:.3g} rad/s there (its own bound on its rates), so it turns no tighter than a radius of "
        f"{level / max(fastest, 1e-12):.3g} m at that speed: it will fly wide of its path (vehicles/turn.py), got a "
        f"turn of radius {level / rate:.3g} m"
    )


_HALVINGS = 24  # the controller's fastest rate to 6e-8 of the turn's


def _judged(model: VehicleModel, plant: VehicleParams, drive: Drive, speed: float, rate: float) -> Judged:
    """(the steady turn, (the yaw moment and the thrust the vehicle has in it), its least radius [m] at that speed
    if it falls short), once per fleet: alike vehicles on like paths turn alike (a fleet of 1000 took 14 s). drive:
    its fins (None: ideal) and its propeller's thrust."""
    return _JUDGED.get((model, plant, drive, speed, rate), lambda: _judge(model, plant, drive, speed, rate))


def _judge(model: VehicleModel, plant: VehicleParams, drive: Drive, speed: float, rate: float) -> Judged:
    (fins, thrust), found = drive, turn(model, plant, speed, rate)
    surge = speed if found is None else found.surge
    has = plant.max_torque if fins is None else min(plant.max_torque, fins.torque_limit(surge))
    if found is not None and abs(found.moment) <= has and found.thrust <= thrust:
        return found, (has, thrust), 0.0
    return found, (has, thrust), speed / max(fastest_turn(model, plant, speed, (has, thrust), rate), 1e-12)


Drive = tuple[Actuators | None, float]
Judged = tuple[Turn | None, tuple[float, float], float]
_JUDGED: Memo[Judged] = Memo()


def _turns(sc: Scenario, section: VehicleSection) -> Iterator[tuple[float, float, float]]:
    """(speed along the path [m/s], yaw rate its tangent turns at [rad/s], its horizontal speed [m/s]) along the
    stretch the run flies from the vehicle's gamma0 (authority_checks.sample_gammas, COARSE points), and densely
    (FINE points) between two whose tangents turn further apart than the faster of their rates explains: a turn
    between them (a lawnmower's, on its legs' 0). At [saturation] top_speed where the path would be faster."""
    path, v_r, top = build_path(section.path), sc.coordination.v_r, top_speed_of(sc, section.id)
    run = v_r * sc.scenario.duration
    coarse = [_point(path, g) for g in sample_gammas(path, initial_gamma(sc, section.id), run, COARSE)]
    points = coarse[:1]
    for before, after in itertools.pairwise(coarse):
        points += [_point(path, g) for g in _between(before, after)]
        points.append(after)
    for _, tangent, rate in points:
        if tangent[0] or tangent[1]:
            along = abs(v_r) * math.hypot(*tangent)
            held = 1.0 if top is None or along <= top else top / along  # gamma_dot held to top / |p_d'|
            yield held * along, held * abs(v_r) * rate, held * abs(v_r) * math.hypot(tangent[0], tangent[1])


Point = tuple[float, tuple[float, float, float], float]  # gamma, p_d'(gamma), its course's turn per unit of gamma


def _between(before: Point, after: Point) -> list[float]:
    """FINE gammas strictly between two points whose tangents turn apart by more than 1.5 times the faster of
    their rates over the gap (a turn the two do not see), else none."""
    (g0, t0, r0), (g1, t1, r1) = before, after
    turned = abs(atan2(t0[0] * t1[1] - t0[1] * t1[0], t0[0] * t1[0] + t0[1] * t1[1]))
    hidden = turned > 1.5 * max(r0, r1) * abs(g1 - g0) + 1e-9
    return [float(g) for g in np.linspace(g0, g1, FINE)[1:-1]] if hidden else []


COARSE, FINE = 128, 64  # points along the stretch; points between two with a turn between them


def _point(path: Path, gamma: float) -> Point:
    """gamma, p_d'(gamma) and the rate its horizontal course turns at per unit of gamma (0 where it is vertical)."""
    _, (dx, dy, dz), (ddx, ddy, _) = path.evaluate_floats(gamma)
    level = dx * dx + dy * dy
    return gamma, (dx, dy, dz), (abs(dx * ddy - dy * ddx) / level if level > 0.0 else 0.0)

"""Paths that turn tighter than a vehicle can, said as warnings by `cpf validate` and `cpf run`.

Flying its path at v_r, a vehicle's heading must turn as the path's tangent does: at the yaw rate v_r psi'(gamma),
psi' the horizontal course's turn per unit of gamma, at the speed v_r |p_d'(gamma)|. A steady turn at that rate
takes a yaw moment (vehicles.turn: the yaw damping, the Munk moment and the lift's at the drift angle where the sway
balances), and the rudder gives at most the vehicle's max_torque (on fins, what they give at the turn's surge, within
it). Where the turn needs more, the vehicle flies a wider circle than its path, whatever its controller: on the
remus100 at 1.5 m/s the least radius is 3.04 m, and a circle of 2 m is flown 1.65 m off its path
(tests/test_turn.py). Each vehicle is judged where its path turns fastest along the stretch its run flies (_turns:
sampled, and densely where the tangent turns between two samples more than their rates explain, as at a lawnmower's
turns); the current, a climb and the controller's transient are left out, and a model of someone else's that cannot
say is too.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import numpy as np

from numerics import atan2
from supervisor.config.authority_checks import sample_gammas
from supervisor.config.fleet import build_path
from supervisor.config.plant import actuators_of, plant_of
from supervisor.config.scenario_schema import Scenario, VehicleSection
from supervisor.config.vehicle_models import vehicle_of
from vehicles.paths import Path
from vehicles.turn import fastest_turn, turn


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
    speed, rate = max(_turns(sc, section), key=lambda turning: (turning[1], turning[0]), default=(0.0, 0.0))
    if rate <= 0.0:
        return None
    model = vehicle_of(sc, section.id)
    nominal = model.parameters()
    plant = plant_of(sc, section.id) or nominal
    found = turn(model, plant, speed, rate)
    fins = actuators_of(sc, section.id, nominal)
    surge = speed if found is None else found.surge
    has = plant.max_torque if fins is None else min(plant.max_torque, fins.torque_limit(surge))
    if found is not None and abs(found.moment) <= has:
        return None
    widest = speed / max(fastest_turn(model, plant, speed, has, rate), 1e-12)
    need = "a drift past 45 deg" if found is None else f"a yaw moment of {abs(found.moment):.3g} N m"
    source = "its max_torque" if fins is None else "its fins at that speed, within its max_torque"
    return (
        f"vehicles[{index}].path: vehicle {section.id} must turn at {rate:.3g} rad/s to follow it at {speed:.3g} m/s "
        f"(v_r {sc.coordination.v_r:g}) and that takes {need}; {source} gives {has:.3g} N m, so it turns no tighter "
        f"than a radius of {widest:.3g} m at that speed: it will fly wide of its path (vehicles/turn.py), got a turn "
        f"of radius {speed / rate:.3g} m"
    )


def _turns(sc: Scenario, section: VehicleSection) -> Iterator[tuple[float, float]]:
    """(speed along the path [m/s], yaw rate its tangent turns at [rad/s]) along the stretch the run flies
    (authority_checks.sample_gammas, COARSE points), and densely (FINE points) between two whose tangents turn
    further apart than the faster of their rates explains: a turn between them (a lawnmower's, on its legs' 0)."""
    path, v_r = build_path(section.path), sc.coordination.v_r
    run = v_r * sc.scenario.duration
    coarse = [_point(path, g) for g in sample_gammas(path, section.gamma0, run, COARSE)]
    points = coarse[:1]
    for before, after in itertools.pairwise(coarse):
        points += [_point(path, g) for g in _between(before, after)]
        points.append(after)
    for _, tangent, rate in points:
        if tangent[0] or tangent[1]:
            yield abs(v_r) * math.hypot(*tangent), abs(v_r) * rate


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

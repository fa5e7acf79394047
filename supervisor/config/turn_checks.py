"""Paths that turn tighter than a vehicle can, said as warnings by `cpf validate` and `cpf run`.

Flying its path at v_r, a vehicle's heading must turn as the path's tangent does: at the yaw rate v_r psi'(gamma),
psi' the horizontal course's turn per unit of gamma, at the speed v_r |p_d'(gamma)|. A steady turn at that rate
takes a yaw moment (vehicles.turn: the yaw damping, the Munk moment and the lift's at the drift angle where the sway
balances), and the rudder gives at most the vehicle's max_torque (on fins, what they give at the turn's surge, within
it). Where the turn needs more, the vehicle flies a wider circle than its path, whatever its controller: on the
remus100 at 1.5 m/s the least radius is 3.0 m, and a circle of 2 m is flown about 3 m wide, 1.65 m off its path
(tests/test_turn.py). Each vehicle is judged at the sampled point (authority_checks.sample_gammas) where its path turns
fastest; the current, a climb and the controller's transient are left out, and a model of someone else's that
cannot say is too.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from supervisor.config.authority_checks import sample_gammas
from supervisor.config.fleet import build_path
from supervisor.config.plant import actuators_of, plant_of
from supervisor.config.scenario_schema import Scenario, VehicleSection
from supervisor.config.vehicle_models import vehicle_of
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
    """(speed along the path [m/s], yaw rate its tangent turns at [rad/s]) at the path's sampled points."""
    path, v_r = build_path(section.path), abs(sc.coordination.v_r)
    for gamma in sample_gammas(path, section.gamma0, v_r * sc.scenario.duration):
        _, (dx, dy, dz), (ddx, ddy, _) = path.evaluate_floats(gamma)
        level = dx * dx + dy * dy
        if level > 0.0:
            yield v_r * math.sqrt(level + dz * dz), v_r * abs(dx * ddy - dy * ddx) / level

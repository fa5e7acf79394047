"""A vehicle while its computer is down (a vehicle_kill until its restart), and where its controller picks up.

The vehicle does not stop when its process dies: the water and its momentum carry it on. `coast` integrates its
plant (its true parameters, vehicles.plant, in the ocean current, vehicles.current) with **no control inputs**:
no thrust, no fin or rudder moment. Chosen over holding the last inputs because a dead computer commands nothing:
an AUV's motor and fin drivers stop on losing their commands (the watchdog every vehicle's safety case asks for),
and a propeller held at cruise thrust with a rudder held at its last angle would be a vehicle circling blind, which
no operator accepts. So the vehicle glides on, slowing under its drag, turning as its own dynamics (the Munk
moment, damping, restoring moments) make it, and drifting with the current; a vehicle not neutrally buoyant rises or
sinks. The actuators (vehicles.actuators) are taken at rest (shaft stopped, fins centred), which is where a
restarted vehicle's actuators start (vehicles.actuators.START).

It coasts from its last recorded state (the only thing of the process that survives it: the state message of the
step before the kill) to the restart, in steps of the run's dt with classical RK4, as vehicles.agent steps the
closed loop, in floats (the same bits on every CPU and in every engine). The last step before the kill, which the
process integrated under control but never reported, is coasted too: one step of dt without inputs.

`resumed` is the vehicle the restarted controller starts from: the coasted state, at the gamma of the path point
nearest to where the vehicle now is (vehicles.nearest; searched around the gamma it had, carried on at its last
rate, so a circle's lap is the one it was on), with the gamma_dot of that point's motion (the vehicle's velocity
over ground along the path's tangent). Not the old gamma: the controller would then steer back to where the vehicle
was when its computer died, cutting across its path to a target left behind.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from comms.records.records import FloatArray
from vehicles.agent import VehicleConfig, VehicleState
from vehicles.current import body_to_inertial
from vehicles.dynamics import reorthonormalize
from vehicles.nearest import nearest_gamma
from vehicles.plant import plant_rates

NO_INPUTS = (0.0, 0.0, 0.0)


def coast(cfg: VehicleConfig, x: FloatArray, t: float, steps: int, dt: float) -> FloatArray:
    """The state x of time t after `steps` steps of dt with no control inputs (module docstring)."""
    s = cfg.model.lift(x)
    for n in range(steps):
        at = t + n * dt
        k1 = _rates(cfg, at, s)
        k2 = _rates(cfg, at + dt / 2, _advance(s, dt / 2, k1))
        k3 = _rates(cfg, at + dt / 2, _advance(s, dt / 2, k2))
        k4 = _rates(cfg, at + dt, _advance(s, dt, k3))
        h = dt / 6
        s = reorthonormalize(
            [a + h * (b1 + 2 * b2 + 2 * b3 + b4) for a, b1, b2, b3, b4 in zip(s, k1, k2, k3, k4, strict=True)]
        )
    return cfg.model.lower(s)


def _advance(s: Sequence[float], h: float, rates: Sequence[float]) -> list[float]:
    return [a + h * b for a, b in zip(s, rates, strict=True)]


def _rates(cfg: VehicleConfig, t: float, s: Sequence[float]) -> tuple[float, ...]:
    """xdot of the lifted state s with no inputs: the true plant's, in the current."""
    return plant_rates(cfg.vehicle, cfg.plant or cfg.params, cfg.current, t, s, None, NO_INPUTS)


def resumed(cfg: VehicleConfig, last: VehicleState, steps: int, dt: float) -> VehicleState:
    """The vehicle a restarted controller starts from, `steps` steps of dt after its last recorded state `last`:
    coasted, at the path point nearest to it, with nothing of the old controller (estimates, observer, memory,
    actuators: they start again as at the run's start)."""
    x = coast(cfg, last.x, last.t, steps, dt)
    t = last.t + steps * dt
    s = cfg.model.lift(x)
    reference = last.gamma + last.gamma_dot * (t - last.t)
    point = [s[0], s[1], s[2]]
    if cfg.model.dim == 2:  # a planar vehicle ignores z: measure in the path's own plane
        point[2] = cfg.path.evaluate_floats(reference)[0][2]
    gamma = nearest_gamma(cfg.path, np.array(point, dtype=float), reference)
    return VehicleState(t, x, gamma, _along_path_rate(cfg, s, t, gamma))


def _along_path_rate(cfg: VehicleConfig, s: Sequence[float], t: float, gamma: float) -> float:
    """d gamma / dt of the nearest point for a vehicle moving with its velocity over ground (to first order: the
    velocity's part along dp_d/dgamma over |dp_d/dgamma|^2); 0 where the path does not move with gamma."""
    _, slope, _ = cfg.model.path_seen(cfg.path.evaluate_floats(gamma))
    vx, vy, vz = body_to_inertial(s[3:12], (s[12], s[13], s[14]))
    if cfg.current is not None:  # the state's v is relative to the water (vehicles.current): over ground add v_c
        cx, cy, cz = cfg.current.velocity(t, s[2])
        vx, vy, vz = vx + cx, vy + cy, vz + cz
    if cfg.model.dim == 2:
        vz = 0.0
    size2 = slope[0] * slope[0] + slope[1] * slope[1] + slope[2] * slope[2]
    return 0.0 if size2 == 0.0 else (vx * slope[0] + vy * slope[1] + vz * slope[2]) / size2

"""Estimating what the nominal model lacks on the actuated velocities: a disturbance observer on u, q and r.

A controller that inverts its nominal model (M nu_dot = f(nu) + tau) on a plant that differs from it (mass, inertia,
damping, restoring, lift; a current that changes) meets a lumped input it does not know, d = M nu_dot - f(nu) - tau,
with M and f the nominal ones. With it unknown, a proportional rate loop settles where k2 M (nu - nu_v) equals d: on a
REMUS 100 on its fins, a heave mass 20 % above nominal and a surge mass 15 % below (a Munk term 59 % larger) leave the
pitch rate 0.02 rad/s off the rate the guidance asks for, the whole rate a nearly saturated fin allows, and the vehicle
holds its pitch while it sinks away from its path (inline5, seed 3: 70 m, measured before this observer). The
disturbance observer (Ohnishi's; Chen, Yang, Guo & Li, "Disturbance-observer-based control and related methods: an
overview", IEEE Trans. Ind. Electron. 63(2), 2016, Sec. II) low-passes the measured d, d_hat' = lambda (d - d_hat), and
the controller subtracts d_hat from its inputs, so for a d that changes slowly against lambda the loop behaves as on the
nominal plant (d_hat -> d exponentially, at the rate lambda, for a constant d).

d is computed once per step from the RK4 stages the vehicle steered at, as vehicles.supervisory's estimators do:
M (nu(t + dt) - nu(t)) / dt, which RK4 makes the weighted mean of the stages' accelerations, less the nominal
model's prediction averaged the same way, with the inputs the vehicle got (its actuators' output, not the command).
On a plant with the nominal parameters d is 0 to rounding. The filter is the exact discretisation of the equation
above for d held over the step.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from numerics import exp
from vehicles.geometry import Float3
from vehicles.params import VehicleParams
from vehicles.path_following import Stage, stage_mean, step_mean
from vehicles.vehicle_model import VehicleModel

NONE: Float3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class Disturbance:
    """The estimate d_hat on (u, q, r) [N, N m, N m]: what the plant adds to the nominal model's inputs."""

    inputs: Float3 = NONE


NO_DISTURBANCE = Disturbance()  # frozen: one for every controller that estimates none (observer = 0), not one a stage


def measured(
    model: VehicleModel, params: VehicleParams, stages: Sequence[Stage], after: Sequence[float], dt: float
) -> Float3:  # fmt: skip
    """d over a step [N, N m, N m]: M times the accelerations of u, q and r the step shows, less the nominal model's
    with the inputs the vehicle got, both averaged as RK4 averages its stages."""
    model_mean, seen = stage_mean(model, params, stages), step_mean(stages[0][0], after, dt)
    return (
        params.mass[0] * (seen[0] - model_mean[0]),
        params.inertia[1] * (seen[4] - model_mean[4]),
        params.inertia[2] * (seen[5] - model_mean[5]),
    )


def filtered(estimate: Disturbance, d: Float3, rate: float, dt: float) -> Disturbance:
    """d_hat after a step of dt with d held: d_hat + (1 - exp(-rate dt)) (d - d_hat)."""
    gain = 1.0 - exp(-rate * dt)
    old = estimate.inputs
    return Disturbance(
        (old[0] + gain * (d[0] - old[0]), old[1] + gain * (d[1] - old[1]), old[2] + gain * (d[2] - old[2]))
    )

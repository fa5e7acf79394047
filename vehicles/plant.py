"""The plant as it differs from the controller's model: its own parameters (model mismatch) and the ocean current.

The controller (vehicles.path_following) computes its inputs with the nominal parameters and, unless the scenario
says the current is known, in still water. The plant then moves with its own parameters and in the current:
    xdot = kinematics(x, drift_plant(x) + B tau / M_plant) + (v_c(t, p), 0, ...)
(p_dot = R v_r + v_c, vehicles.current). With neither, the closed loop (vehicles.agent) uses the controller's drift
and plain kinematics, exactly as before either existed.
"""

from __future__ import annotations

from collections.abc import Sequence

from vehicles.current import Current
from vehicles.dynamics import Accelerations, kinematics, with_inputs
from vehicles.geometry import Float3
from vehicles.params import VehicleParams
from vehicles.vehicle_model import VehicleModel


def plant_rates(
    model: VehicleModel,
    plant: VehicleParams,
    current: Current | None,
    t: float,
    s: Sequence[float],
    drift: Accelerations | None,
    tau: Float3,
) -> tuple[float, ...]:
    """xdot of the lifted state s at time t for inputs tau; drift: the accelerations with no input if already
    known for these parameters (the controller's, when the plant is nominal), else None."""
    acc = model.drift(s, plant) if drift is None else drift
    xdot = kinematics(s, with_inputs(acc, tau, plant))
    if current is None:
        return xdot
    cx, cy, cz = current.velocity(t, s[2])
    return (xdot[0] + cx, xdot[1] + cy, xdot[2] + cz, *xdot[3:])

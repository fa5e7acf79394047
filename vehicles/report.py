"""A vehicle's state report: what it says about step k, built from its telemetry and its model.

Only the vehicle knows how its state vector maps to a position, an attitude and velocities (planar vehicles are
embedded in 3-D here), so the report is built on this side; comms only defines the record and its wire form.
"""

from __future__ import annotations

from comms.messages import Message
from vehicles.agent import Telemetry
from vehicles.dynamics import Model


def state_message(
    telemetry: Telemetry, model: Model, k: int, tx_seq: int, ages: tuple[tuple[int, float], ...] = ()
) -> Message:
    """A vehicle's telemetry of step k (planar vehicles embedded in 3-D); tx_seq: its transmission then, or 0;
    ages: how old each neighbour estimate it holds is."""
    s = model.spatial(telemetry.x)
    error = telemetry.error.tolist() + [0.0] * (3 - len(telemetry.error))
    return {
        "t": telemetry.t,
        "k": k,
        "vehicle": telemetry.vehicle_id,
        "gamma": telemetry.gamma,
        "gamma_dot": telemetry.gamma_dot,
        "position": s.position.tolist(),
        "rotation": s.rotation.reshape(9).tolist(),
        "velocity": s.velocity.tolist(),
        "angular_velocity": s.angular_velocity.tolist(),
        "error": error,
        "tau": telemetry.tau.tolist(),
        "correction": telemetry.correction,
        "lyapunov": telemetry.lyapunov,
        "tx_seq": tx_seq,
        "estimate_age": [[j, age] for j, age in ages],
    }

"""A vehicle's state report: what it says about step k, built from its telemetry and its model.

Only the vehicle knows how its state vector maps to a position, an attitude and velocities (planar vehicles are
embedded in 3-D here), so the report is built on this side; comms only defines the record
(comms.records.state.StateReport) and its wire form.
"""

from __future__ import annotations

from comms.records.messages import Message
from comms.records.state import NeighbourAge, StateReport
from vehicles.agent import Telemetry
from vehicles.dynamics import Model
from vehicles.estimates import NeighbourEstimate
from vehicles.navigation import NavOutput


def state_message(
    telemetry: Telemetry, model: Model, k: int, tx_seq: int, ages: tuple[NeighbourAge, ...] = ()
) -> Message:
    """A vehicle's telemetry of step k as its state message (state_report's wire form)."""
    return state_report(telemetry, model, k, tx_seq, ages).to_message()


def state_report(
    telemetry: Telemetry,
    model: Model,
    k: int,
    tx_seq: int,
    ages: tuple[NeighbourAge, ...] = (),
    nav: NavOutput | None = None,
    frozen: NeighbourEstimate | None = None,
) -> StateReport:
    """A vehicle's telemetry of step k (planar vehicles embedded in 3-D); tx_seq: its transmission then, or 0;
    ages: how old each neighbour estimate it holds is; nav: its navigation computer's step, if it has one; frozen:
    its stuck gamma sensor's reading, while it is stuck."""
    # The lifted state is the spatial layout [p, R (row-major), v, omega] in floats, for both models: the same
    # numbers as model.spatial's arrays, without an array per quantity.
    s = model.lift(telemetry.x)
    error = telemetry.error.tolist() + [0.0] * (3 - len(telemetry.error))
    return StateReport(
        telemetry.t, k, telemetry.vehicle_id, telemetry.gamma, telemetry.gamma_dot, (s[0], s[1], s[2]),
        tuple(s[3:12]), (s[12], s[13], s[14]), (s[15], s[16], s[17]),
        _three(error), tuple(telemetry.tau.tolist()), telemetry.correction, telemetry.lyapunov, tx_seq, ages,
        nav_estimate=None if nav is None else nav.posterior.flat(), nav_fix=None if nav is None else nav.fix,
        current_estimate=telemetry.current_estimate,
        frozen=None if frozen is None else (frozen.gamma, frozen.gamma_dot),
    )  # fmt: skip


def _three(values: list[float]) -> tuple[float, float, float]:
    return values[0], values[1], values[2]

"""A vehicle's step and the records it leaves: the one path from vehicles.runtime.node_step to the state message
(and the transmission's message), shared by the in-process engine, the vehicle process and re-simulation.

The state message of step k carries the sequence number of the transmission made at it (0: none), so that a
restarted process resumes its numbering; building it anywhere else would let the engines drift apart.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import msgspec
import numpy as np

from comms.records.fields import MAX_SPEED
from comms.records.messages import Message, tx_message
from comms.records.records import Disturbances, Heard, Transmission
from comms.records.state import StateReport
from vehicles.agent import VehicleConfig
from vehicles.report import state_report
from vehicles.runtime import NodeState, Radio, StepOutput, node_step

# How vehicles.guard's errors begin (its labels).
EXTENSION_KINDS = ("law ", "predictor ", "transmission ", "controller ", "model ")


class StepRecords(msgspec.Struct, frozen=True):
    """What one vehicle step puts on the record: its state (as a record, and as the message built from it), its
    transmission (if it made one) and that transmission's message. The messages are built when asked for, each time:
    a sweep's run counts them without building them (supervisor.engine.inprocess, a Tally)."""

    transmission: Transmission | None
    report: StateReport  # the state message as a record: an engine in this process needs not parse it back

    @property
    def state(self) -> Message:
        return self.report.to_message()

    @property
    def tx(self) -> Message | None:
        return tx_message(self.transmission) if self.transmission is not None else None


def step_records(
    cfg: VehicleConfig,
    radio: Radio,
    node: NodeState,
    k: int,
    t: float,
    dt: float,
    heard: Sequence[Heard],
    neighbours: Sequence[int],
    dist: Disturbances,
) -> tuple[NodeState, StepRecords]:
    """Step k (at t = k dt) of one vehicle: node_step, then the messages that record it."""
    try:
        node, out = node_step(cfg, radio, node, t, dt, heard, neighbours, dist)
    except (np.linalg.LinAlgError, ArithmeticError) as exc:  # a state gone to nan/inf, or an extension failed
        if isinstance(exc, FloatingPointError) and str(exc).startswith(EXTENSION_KINDS):  # vehicles.guard's
            raise FloatingPointError(f"vehicle {cfg.vehicle_id} at t = {t:.1f} s: {exc}") from None
        raise FloatingPointError(f"vehicle {cfg.vehicle_id} diverged at t = {t:.1f} s ({exc})") from None
    return node, records(cfg, k, t, out)


def records(cfg: VehicleConfig, k: int, t: float, out: StepOutput) -> StepRecords:
    """The records of a vehicle's step k (at t) from its output; FloatingPointError if its state is not sane."""
    sent = out.transmission
    seq, stuck = sent.seq if sent else 0, out.frozen
    report = state_report(out.telemetry, cfg.model, k, seq, out.estimate_ages, out.navigation, stuck)
    _check_sane(report, t)
    return StepRecords(sent, report)


def _check_sane(report: StateReport, t: float) -> None:
    """FloatingPointError for a vehicle whose closed loop diverged (a step too long for its dynamics, gains too
    high): its state not finite, or faster than any vehicle (MAX_SPEED). Every engine stops it the same way, at the
    step it happens, instead of handing the channel a state no reader accepts."""
    values = (*report.position, *report.velocity, *report.rotation, *report.angular_velocity)
    speed = math.hypot(*report.velocity)
    if all(map(math.isfinite, values)) and speed <= MAX_SPEED:  # map: no generator frame per value
        return
    what = "state is not finite" if not math.isfinite(speed) else f"speed is {speed:.3g} m/s (over {MAX_SPEED:g})"
    raise FloatingPointError(
        f"vehicle {report.vehicle} diverged at t = {t:.1f} s: its {what}; a shorter step or smaller gains may help"
    )

"""A vehicle's step and the records it leaves: the one path from vehicles.runtime.node_step to the state message
(and the transmission's message), shared by the in-process engine, the vehicle process and re-simulation.

The state message of step k carries the sequence number of the transmission made at it (0: none), so that a
restarted process resumes its numbering; building it anywhere else would let the engines drift apart.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from comms.messages import Message, tx_message
from comms.records import Disturbances, Heard, Transmission
from comms.state import StateReport
from vehicles.agent import VehicleConfig
from vehicles.report import state_report
from vehicles.runtime import NodeState, Radio, node_step


@dataclass(frozen=True, slots=True)
class StepRecords:
    """What one vehicle step puts on the record: its state message, its transmission (if it made one) and that
    transmission's message."""

    state: Message
    transmission: Transmission | None
    tx: Message | None
    report: StateReport  # the state message as a record: an engine in this process needs not parse it back


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
    node, out = node_step(cfg, radio, node, t, dt, heard, neighbours, dist)
    sent = out.transmission
    report = state_report(out.telemetry, cfg.model, k, sent.seq if sent else 0, out.estimate_ages)
    return node, StepRecords(report.to_message(), sent, tx_message(sent) if sent else None, report)

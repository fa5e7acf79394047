"""What a vehicle process serves a vehicle with, whole, handed over in a private file of the run (comms.bus.handover:
why pickle, and why it is safe).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from comms.bus.handover import read_private
from comms.records.fields import Message
from vehicles.agent import VehicleConfig
from vehicles.runtime import NodeState, Radio


@dataclass(frozen=True, slots=True)
class VehicleStart:
    """Everything vehicles.node.run_vehicle serves one vehicle with, but the bus (endpoint, credential)."""

    cfg: VehicleConfig
    initial: NodeState  # at start_step: the scenario's initial state, or a restarted vehicle's last recorded one
    radio: Radio
    neighbours: tuple[int, ...]  # the scenario's graph, until a tick says otherwise
    dt: float
    hello: Message  # its answer to which scenario it runs (comms.records.messages.Hello): the supervisor's own digests
    start_step: int = 0


WHAT = "vehicle starts written by cpf run"


def read_starts(path: Path) -> tuple[VehicleStart, ...]:
    """The starts the supervisor wrote (comms.bus.handover.write_private, a tuple); ValueError '<file>: <problem>'
    for a file that is not a private file of this user's holding them."""
    starts = read_private(path, tuple, WHAT)
    if not all(isinstance(s, VehicleStart) for s in starts):
        raise ValueError(f"{path}: not {WHAT} (a tuple of {', '.join(sorted({type(s).__name__ for s in starts}))})")
    return starts

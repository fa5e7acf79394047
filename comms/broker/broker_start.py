"""What the broker process serves the channel with, whole, handed over in a private file of the run (comms.bus.handover:
why pickle, and why it is safe). The supervisor builds it (supervisor.config.broker_start) for the broker it starts,
which then imports neither pydantic nor the scenario's schema: its start-up CPU halves (0.24 -> 0.12 s measured).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from comms.broker.broker_core import BrokerCore
from comms.bus.handover import read_private
from comms.records.fields import Message

WHAT = "a broker start written by cpf run"


@dataclass(frozen=True, slots=True)
class BrokerStart:
    """Everything comms.broker.broker.run_broker serves the channel with, but the bus (endpoint, credential) and the
    step it starts at."""

    core: BrokerCore  # the channel (its random streams from the run's seed), the graph, the link books
    vehicles: tuple[int, ...]
    dt: float
    hello: Message  # its answer to which scenario it runs (comms.records.messages.Hello): the supervisor's own digests


def read_broker_start(path: Path) -> BrokerStart:
    """The start comms.bus.handover.write_private wrote; ValueError '<file>: <problem>' for a file that is not a
    private file of this user's holding one."""
    return read_private(path, BrokerStart, WHAT)

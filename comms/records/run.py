"""The supervisor's announcements about the run on cpf/run/*: the communication graph in force (cpf/run/graph), a
fault starting or ending (cpf/run/fault) and the stop (cpf/run/stop), each a record with its wire form and its
checked reading side by side (schemas comms.records.schemas.GRAPH, FAULT, STOP).

`from_message` raises ValueError naming the field for anything malformed. The run's metadata (cpf/run/meta) is the
supervisor's own record (supervisor.record.meta.RunMeta): it carries the scenario, which comms knows nothing of.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal, cast

from comms.records.fields import Message, get, is_int, number

Edge = tuple[int, int]
PHASES = ("start", "end")
Phase = Literal["start", "end"]


def links_message(edges: Iterable[Edge]) -> list[Message]:
    """Directed links as a message has them: objects, which viewers can read (an array of arrays they cannot)."""
    return [{"sender": i, "receiver": j} for i, j in edges]


def edges_of(message: Message, name: str) -> tuple[Edge, ...]:
    """The directed links of links_message (or, in logs before it, [sender, receiver] pairs) as vehicle-id pairs."""
    return tuple(link_of(item, name) for item in get(message, name, list))


def link_of(item: object, name: str) -> Edge:
    """One link of a list: {"sender": i, "receiver": j}, or an older log's [i, j]."""
    pair = [item.get("sender"), item.get("receiver")] if isinstance(item, dict) else item
    if not (isinstance(pair, list) and len(pair) == 2 and is_int(pair[0]) and is_int(pair[1])):
        raise ValueError(f"field {name!r} is not a list of links (sender and receiver vehicle ids)")
    return pair[0], pair[1]


@dataclass(frozen=True, slots=True)
class Graph:
    """The communication graph in force from time t: its directed edges."""

    t: float
    edges: tuple[Edge, ...]

    @classmethod
    def of(cls, t: float, edges: Iterable[Edge]) -> Graph:
        return cls(t, tuple((i, j) for i, j in edges))

    def to_message(self) -> Message:
        return {"t": self.t, "edges": links_message(self.edges)}

    @classmethod
    def from_message(cls, message: Message) -> Graph:
        return cls(number(message, "t"), edges_of(message, "edges"))


@dataclass(frozen=True, slots=True)
class FaultEvent:
    """A fault starting or ending with the step at t: its kind and its scenario fields but the kind (detail: the
    vehicle or link it acts on, its numbers, its start and end)."""

    t: float
    kind: str
    phase: Phase
    detail: dict[str, object]

    def to_message(self) -> Message:
        return {"t": self.t, "kind": self.kind, "phase": self.phase, "detail": self.detail}

    @classmethod
    def from_message(cls, message: Message) -> FaultEvent:
        phase = get(message, "phase", str)
        if phase not in PHASES:
            raise ValueError(f"field 'phase' is {phase!r}, not one of {', '.join(PHASES)}")
        detail = get(message, "detail", dict)
        if not all(isinstance(name, str) for name in detail):
            raise ValueError("field 'detail' has a key that is not a string")
        return cls(number(message, "t"), get(message, "kind", str), cast(Phase, phase), detail)


@dataclass(frozen=True, slots=True)
class Stop:
    """The supervisor's stop at time t: the reason is comms.records.messages.STOP_END when the run finished, else why it
    stopped early (e.g. a process refused)."""

    t: float
    reason: str

    def to_message(self) -> Message:
        return {"t": self.t, "reason": self.reason}

    @classmethod
    def from_message(cls, message: Message) -> Stop:
        return cls(number(message, "t"), get(message, "reason", str))

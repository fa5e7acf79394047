"""The supervisor's announcements about the run on cpf/run/*: the run's metadata (cpf/run/meta), the communication
graph in force (cpf/run/graph), a fault starting or ending (cpf/run/fault) and the stop (cpf/run/stop). Each is a
msgspec Struct, its message's only description: the message (`to_message`), its reading (`from_message`, ValueError
naming the field for anything malformed) and its JSON Schema (comms.records.schemas, generated) come from it.

Directed links are objects {sender, receiver} in a message (viewers read no arrays of arrays); logs written before
that have [sender, receiver] pairs, which read the same (`older_links`). The run's metadata carries the scenario,
which comms knows nothing of: here it is a free map; the supervisor builds it (supervisor.record.meta.RunMeta.of).
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from typing import Annotated, Any, Literal, Self, TypeVar

import msgspec

from comms.records.fields import Finite, Message, as_message, is_int, read_as

Edge = tuple[int, int]
Phase = Literal["start", "end"]
S = TypeVar("S", bound=msgspec.Struct)


class Link(msgspec.Struct, frozen=True, order=True):
    """A directed link as a message has it."""

    sender: int
    receiver: int

    @property
    def pair(self) -> Edge:
        return self.sender, self.receiver


def links(edges: Iterable[Edge]) -> tuple[Link, ...]:
    return tuple(Link(i, j) for i, j in edges)


def pairs(items: Iterable[Link]) -> tuple[Edge, ...]:
    return tuple((link.sender, link.receiver) for link in items)


def read_struct(message: object, kind: type[S], names: tuple[str, ...]) -> S:
    """The struct `kind` of a message whose fields `names` are lists of links, read in today's form or (an older log)
    as [sender, receiver] pairs; ValueError naming the field for anything malformed."""
    try:
        return read_as(message, kind)
    except ValueError:
        older = older_links(message, names)
        if older is None:
            raise
        return read_as(older, kind)


def older_links(message: object, names: tuple[str, ...]) -> Message | None:
    """A message of a log from before links were objects, its links `names` in today's form; None for anything else
    (a message in today's form, or malformed)."""
    if not isinstance(message, dict):
        return None
    changed = {name: _objects(message.get(name)) for name in names}
    if all(value is None for value in changed.values()):
        return None
    return {**message, **{name: value for name, value in changed.items() if value is not None}}


def _objects(items: object) -> list[Message] | None:
    if not (isinstance(items, list) and items and all(isinstance(item, list) for item in items)):
        return None
    if not all(len(pair) == 2 and is_int(pair[0]) and is_int(pair[1]) for pair in items):
        return None
    return [{"sender": i, "receiver": j} for i, j in items]


class Graph(msgspec.Struct, frozen=True):
    """The communication graph in force from time t: its directed links (`edges`: as vehicle-id pairs)."""

    t: Finite
    links: tuple[Link, ...] = msgspec.field(name="edges")

    @classmethod
    def of(cls, t: float, edges: Iterable[Edge]) -> Graph:
        return cls(t, links(edges))

    @property
    def edges(self) -> tuple[Edge, ...]:
        return pairs(self.links)

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> Graph:
        return read_struct(message, cls, ("edges",))


Detail = dict[str, Any]


class FaultEvent(msgspec.Struct, frozen=True):
    """A fault starting or ending with the step at t: its kind and its scenario fields but the kind (detail: the
    vehicle or link it acts on, its numbers, its start and end)."""

    t: Finite
    kind: str
    phase: Phase
    detail: Detail

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> FaultEvent:
        return read_as(message, cls)


class Stop(msgspec.Struct, frozen=True):
    """The supervisor's stop at time t: the reason is comms.records.messages.STOP_END when the run finished, else why it
    stopped early (e.g. a process refused)."""

    t: Finite
    reason: str

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> Stop:
        return read_as(message, cls)


class RunMeta(msgspec.Struct, frozen=True):
    """What ran: the scenario (its name, file, text, and as validated with --set and --fault applied: enough to
    re-run it), the seed, engine and clock, and the numbers readers need without validating the scenario again."""

    scenario_name: str
    scenario_file: str
    scenario_toml: str
    scenario: dict[str, Any]
    seed: int
    engine: str
    clock: str
    step: Annotated[float, msgspec.Meta(gt=0.0, le=sys.float_info.max)]  # s
    duration: Finite
    vehicles: tuple[int, ...]
    links: tuple[Link, ...] = msgspec.field(name="edges")
    faults: tuple[Detail, ...]  # each fault's scenario fields, its kind included
    tube_radius: Finite
    versions: dict[str, str]
    extensions: tuple[str, ...] = ()  # what the scenario's extensions resolved to; absent in older logs

    @property
    def edges(self) -> tuple[Edge, ...]:
        return pairs(self.links)

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> Self:
        """The metadata, checked: ValueError naming the field for anything malformed."""
        return read_struct(message, cls, ("edges",)).check()

    def check(self) -> Self:
        """What the types cannot say: each fault names its kind."""
        for n, fault in enumerate(self.faults):
            if not isinstance(fault.get("kind"), str):
                raise ValueError(f"field 'faults': item {n} names no kind (a string)")
        return self

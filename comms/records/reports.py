"""The reports processes make about the run as a whole, each a record with its wire form and its checked reading:
the broker's statistics (cpf/comms/stats) and end-of-run report (cpf/comms/done), and a vehicle's end-of-run report
(cpf/vehicle/<id>/done): how many malformed messages each reader counted and dropped.

`from_message` raises ValueError for anything malformed: a count that is not a non-negative integer, a time or a
delay that is not finite and non-negative. Whether a time fits the run is the reader's to say (it knows the run).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from comms.records.fields import Message, get, is_int, number

MAX_KEYS = 64  # keys a report may count malformed messages on: a reader subscribes to a handful


def count(message: Mapping[str, Any], name: str) -> int:
    """A non-negative integer."""
    value: int = get(dict(message), name, int)
    if value < 0:
        raise ValueError(f"field {name!r} is negative")
    return value


def non_negative(message: Mapping[str, Any], name: str) -> float:
    value = number(dict(message), name)
    if value < 0:
        raise ValueError(f"field {name!r} is negative")
    return value


def counts_by_key(message: Message, name: str) -> dict[str, int]:
    """A map of key (a string) to a non-negative count, of at most MAX_KEYS keys."""
    value = get(message, name, dict)
    if len(value) > MAX_KEYS:
        raise ValueError(f"field {name!r} has {len(value)} keys, more than {MAX_KEYS}")
    if not all(isinstance(k, str) and is_int(n) and n >= 0 for k, n in value.items()):
        raise ValueError(f"field {name!r} is not a map of key to a non-negative count")
    return dict(value)


@dataclass(frozen=True, slots=True)
class CommsDone:
    """The broker's end-of-run report (schema comms.records.schemas.COMMS_DONE): the events it published over the run,
    and the malformed messages it dropped."""

    t: float
    k: int
    events: int
    malformed: int

    def to_message(self) -> Message:
        return {"t": self.t, "k": self.k, "events": self.events, "malformed": self.malformed}

    @classmethod
    def from_message(cls, message: Message) -> CommsDone:
        t, k = non_negative(message, "t"), count(message, "k")
        return cls(t, k, count(message, "events"), count(message, "malformed"))


@dataclass(frozen=True, slots=True)
class LinkCounts:
    """One directed link's books in a stats snapshot (comms.broker.stats.LinkBook.as_message)."""

    sender: int
    receiver: int
    sent: int
    delivered: int
    dropped: dict[str, int]
    mean_delay: float | None
    max_delay: float | None

    def to_message(self) -> Message:
        delays = {} if self.mean_delay is None else {"mean_delay": self.mean_delay, "max_delay": self.max_delay}
        return {"sender": self.sender, "receiver": self.receiver, "sent": self.sent, "delivered": self.delivered,
                "dropped": dict(self.dropped), **delays}  # fmt: skip

    @classmethod
    def from_message(cls, item: object) -> LinkCounts:
        if not isinstance(item, dict):
            raise ValueError("a link of the statistics is not a map")
        dropped = counts_by_key(item, "dropped")
        delays = [None if item.get(n) is None else non_negative(item, n) for n in ("mean_delay", "max_delay")]
        return cls(
            get(item, "sender", int), get(item, "receiver", int), count(item, "sent"), count(item, "delivered"),
            dropped, delays[0], delays[1],
        )  # fmt: skip


@dataclass(frozen=True, slots=True)
class CommsStats:
    """The broker's statistics snapshot (schema comms.records.schemas.COMMS_STATS,
    comms.broker.stats.LinkStats.snapshot)."""

    t: float
    window: float
    horizon: float | None
    lambda2: float
    links: tuple[LinkCounts, ...]

    def to_message(self) -> Message:
        message: Message = {"t": self.t, "window": self.window}
        if self.horizon is not None:
            message["horizon"] = self.horizon
        return message | {"lambda2": self.lambda2, "links": [link.to_message() for link in self.links]}

    @classmethod
    def from_message(cls, message: Message) -> CommsStats:
        horizon = None if message.get("horizon") is None else non_negative(message, "horizon")
        links = tuple(LinkCounts.from_message(item) for item in get(message, "links", list))
        return cls(non_negative(message, "t"), non_negative(message, "window"), horizon, number(message, "lambda2"),
                   links)  # fmt: skip


@dataclass(frozen=True, slots=True)
class VehicleDone:
    """A vehicle's end-of-run report on its own done key (schema comms.records.schemas.VEHICLE_DONE): the malformed
    messages it dropped, by the key they came on. Sent once it has run its last step."""

    t: float
    k: int
    vehicle: int
    malformed: dict[str, int]

    def to_message(self) -> Message:
        return {"t": self.t, "k": self.k, "vehicle": self.vehicle, "malformed": dict(self.malformed)}

    @classmethod
    def from_message(cls, message: Message, key_vehicle: int) -> VehicleDone:
        vehicle = get(message, "vehicle", int)
        if vehicle != key_vehicle:
            raise ValueError(f"vehicle {vehicle} published on vehicle {key_vehicle}'s key")
        return cls(non_negative(message, "t"), count(message, "k"), vehicle, counts_by_key(message, "malformed"))

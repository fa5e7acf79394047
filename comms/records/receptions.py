"""A vehicle's reception batch of one sync step: the record, its wire form and its checked reading, side by side.

`RxBatch.to_message` gives the dict on a vehicle's rx key (schema comms.records.schemas.RECEPTIONS), and the batch the
vehicle reports in its step message; `from_message` is its inverse, checked (ValueError for anything malformed).
Each reception is a `Delivery`: what the channel delivered, and in realtime runs when it was due on the wall clock.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from comms.records.fields import Finite, Message, converted, get, number
from comms.records.records import Heard, Reception


@dataclass(frozen=True, slots=True)
class Delivery:
    """One reception as a batch carries it (its receiver is the batch's vehicle). due: realtime deliveries only, the
    wall-clock time (time.time()) at which it should reach the vehicle, so the vehicle can measure how late it did."""

    sender: int
    seq: int
    stamp: Finite  # the time of the data, as the packet carries it
    arrival: Finite  # simulation time
    gamma: Finite
    gamma_dot: Finite
    due: Finite | None = None

    @classmethod
    def of(cls, r: Reception, wall_of: Callable[[float], float] | None = None) -> Delivery:
        """The channel's reception; wall_of (realtime): the wall-clock time of a simulation time."""
        due = None if wall_of is None else wall_of(r.arrival)
        return cls(r.sender, r.seq, r.stamp, r.arrival, r.gamma, r.gamma_dot, due)

    @property
    def heard(self) -> Heard:
        return Heard(self.sender, self.stamp, self.gamma, self.gamma_dot)

    def to_message(self) -> Message:
        item = {"sender": self.sender, "seq": self.seq, "stamp": self.stamp, "arrival": self.arrival,
                "gamma": self.gamma, "gamma_dot": self.gamma_dot}  # fmt: skip
        if self.due is not None:
            item["due"] = self.due
        return item

    @classmethod
    def from_message(cls, item: object) -> Delivery:
        """The reception, checked (ValueError for anything malformed); msgspec's reading, else the checks'."""
        return converted(item, cls) or cls.checked(item)

    @classmethod
    def checked(cls, item: object) -> Delivery:
        if not isinstance(item, dict):
            raise ValueError("a reception is not a map")
        return cls(
            get(item, "sender", int), get(item, "seq", int), number(item, "stamp"), number(item, "arrival"),
            number(item, "gamma"), number(item, "gamma_dot"), None if item.get("due") is None else number(item, "due"),
        )  # fmt: skip


@dataclass(frozen=True, slots=True)
class RxBatch:
    """What vehicle `vehicle` takes in at step k (t: the step's time, or a realtime delivery's arrival)."""

    t: Finite
    k: int
    vehicle: int
    receptions: tuple[Delivery, ...]

    @classmethod
    def of(
        cls, vehicle: int, k: int, t: float, receptions: Sequence[Reception], wall_of: Callable[[float], float] | None
    ) -> RxBatch:
        return cls(t, k, vehicle, tuple(Delivery.of(r, wall_of) for r in receptions))

    @property
    def heard(self) -> list[Heard]:
        return [d.heard for d in self.receptions]

    def timed(self) -> list[tuple[Delivery, float]]:
        """(reception, its due time) of a realtime delivery; ValueError if one has none."""
        timed = [(d, d.due) for d in self.receptions if d.due is not None]
        if len(timed) != len(self.receptions):
            raise ValueError("missing field 'due'")
        return timed

    def to_message(self) -> Message:
        receptions = [d.to_message() for d in self.receptions]
        return {"t": self.t, "k": self.k, "vehicle": self.vehicle, "receptions": receptions}

    @classmethod
    def from_message(cls, message: Message) -> RxBatch:
        """The batch, checked (ValueError for anything malformed); msgspec's reading, else the checks'."""
        return converted(message, cls) or cls.checked(message)

    @classmethod
    def checked(cls, message: Message) -> RxBatch:
        receptions = tuple(Delivery.checked(item) for item in get(message, "receptions", list))
        return cls(number(message, "t"), get(message, "k", int), get(message, "vehicle", int), receptions)

"""A vehicle's reception batch of one sync step: one msgspec Struct, the message's only description.

`RxBatch.to_message` gives the dict on a vehicle's rx key and the batch the vehicle reports in its step message (its
schema comms.records.schemas.RECEPTIONS is generated from the struct); `from_message` is its inverse, checked by
msgspec's types (ValueError naming the field for anything malformed). Each reception is a `Delivery`: what the
channel delivered, and in realtime runs when it was due on the wall clock (left out of the message otherwise).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import msgspec

from comms.records.fields import Finite, Message, as_message, read_as
from comms.records.records import Heard, Reception


class Delivery(msgspec.Struct, frozen=True, omit_defaults=True):
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
        return as_message(self)

    @classmethod
    def from_message(cls, item: object) -> Delivery:
        """The reception, checked: ValueError naming the field for anything malformed."""
        return read_as(item, cls)


class RxBatch(msgspec.Struct, frozen=True):
    """What vehicle `vehicle` takes in at step k (t: the step's time, or a realtime delivery's arrival)."""

    t: Finite
    k: int
    vehicle: int
    receptions: tuple[Delivery, ...]

    @classmethod
    def of(
        cls, vehicle: int, k: int, t: float, receptions: Sequence[Reception], wall_of: Callable[[float], float] | None
    ) -> RxBatch:
        if wall_of is not None:
            return cls(t, k, vehicle, tuple([Delivery.of(r, wall_of) for r in receptions]))
        # Delivery.of without its call per reception: a batch per vehicle per step, in every run of a sweep.
        deliveries = [Delivery(r.sender, r.seq, r.stamp, r.arrival, r.gamma, r.gamma_dot) for r in receptions]
        return cls(t, k, vehicle, tuple(deliveries))

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
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> RxBatch:
        """The batch, checked: ValueError naming the field for anything malformed."""
        return read_as(message, cls)

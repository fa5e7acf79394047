"""The reports processes make about the run as a whole: the broker's statistics (cpf/comms/stats) and end-of-run
report (cpf/comms/done), and a vehicle's end-of-run report (cpf/vehicle/<id>/done): how many malformed messages each
reader counted and dropped.

Each is a msgspec Struct, its message's only description: the message (`to_message`), its checked reading
(`from_message`: ValueError naming the field for a count that is not a non-negative integer, a time or a delay that
is not finite and non-negative) and its JSON Schema (comms.records.schemas, generated) come from it. Whether a time
fits the run is the reader's to say (it knows the run).
"""

from __future__ import annotations

from typing import Annotated

import msgspec

from comms.records.fields import Count, Finite, Message, NonNegative, as_message, read_as

MAX_KEYS = 64  # keys a report may count malformed messages on: a reader subscribes to a handful
CountsByKey = Annotated[dict[str, Count], msgspec.Meta(max_length=MAX_KEYS)]  # key -> a count


class CommsDone(msgspec.Struct, frozen=True, omit_defaults=True):
    """The broker's end-of-run report: the events it published over the run, and the malformed messages it
    dropped."""

    t: NonNegative
    k: Count
    events: Count
    malformed: Count
    causes: CountsByKey = {}  # cause -> messages dropped (comms.records.drops; absent in older logs)
    by_key: CountsByKey = {}  # key -> messages dropped: whose key carried them (absent in older logs)

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> CommsDone:
        return read_as(message, cls)


class LinkCounts(msgspec.Struct, frozen=True, omit_defaults=True):
    """One directed link's books in a stats snapshot (comms.broker.stats.LinkBook.counts): the delays only once a
    packet was delivered (left out, not null; older logs have null)."""

    sender: int
    receiver: int
    sent: Count
    delivered: Count
    dropped: CountsByKey  # by cause
    mean_delay: NonNegative | None = None
    max_delay: NonNegative | None = None

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, item: object) -> LinkCounts:
        return read_as(item, cls)


class CommsStats(msgspec.Struct, frozen=True, omit_defaults=True, kw_only=True):
    """The broker's statistics snapshot (comms.broker.stats.LinkStats.snapshot)."""

    t: NonNegative
    window: NonNegative
    horizon: NonNegative | None = None  # s a delivery keeps its pair in the delivered graph (absent in older logs)
    lambda2: Finite
    links: tuple[LinkCounts, ...]

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> CommsStats:
        return read_as(message, cls)


class VehicleDone(msgspec.Struct, frozen=True, omit_defaults=True):
    """A vehicle's end-of-run report on its own done key: the malformed messages it dropped, by the key they came on.
    Sent once it has run its last step."""

    t: NonNegative
    k: Count
    vehicle: int
    malformed: CountsByKey
    causes: CountsByKey = {}  # cause -> messages dropped (comms.records.drops; absent in older logs)

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object, key_vehicle: int) -> VehicleDone:
        return read_as(message, cls).check(key_vehicle)

    def check(self, key_vehicle: int) -> VehicleDone:
        """What the types cannot say: the vehicle owns the key it came on."""
        if self.vehicle != key_vehicle:
            raise ValueError(f"field 'vehicle': vehicle {self.vehicle} published on vehicle {key_vehicle}'s key")
        return self

"""The reports processes make about the run as a whole: the broker's statistics (cpf/comms/stats) and end-of-run
report (cpf/comms/done), a vehicle's end-of-run report (cpf/vehicle/<id>/done) and the supervisor's (cpf/run/done):
how many malformed messages each reader counted and dropped. `bus_drops` reads the three kinds as one table, the one
`cpf run` prints and writes to --metrics and `cpf report` writes from the log.

Each is a msgspec Struct, its message's only description: the message (`to_message`), its checked reading
(`from_message`: ValueError naming the field for a count that is not a non-negative integer, a time or a delay that
is not finite and non-negative) and its JSON Schema (comms.records.schemas, generated) come from it. Whether a time
fits the run is the reader's to say (it knows the run).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Annotated, NamedTuple

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


class SupervisorDone(msgspec.Struct, frozen=True, omit_defaults=True):
    """The supervisor's end-of-run report (cpf/run/done, in the log only: no process reads it on the bus): the
    malformed messages it dropped, by the key they came on and by cause."""

    t: NonNegative
    k: Count
    malformed: CountsByKey
    causes: CountsByKey = {}  # cause -> messages dropped (comms.records.drops)

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> SupervisorDone:
        return read_as(message, cls)


SUPERVISOR = "supervisor"  # the readers, as the drops tables name them
BROKER = "broker"
BY_NO_KEY = "any key"  # a reader that reports one count, not by key (the broker of older logs)


Counts = dict[str, dict[str, int] | None]  # reader -> key (or cause) -> messages; None: the reader sent no report


class BusDrops(NamedTuple):
    """What the bus's readers dropped: reader -> key -> malformed messages, reader -> cause -> messages (None for a
    reader expected to report that did not)."""

    by_key: Counts
    by_cause: Counts


def bus_drops(
    supervisor: SupervisorDone | None,
    broker: CommsDone | None,
    vehicles: Mapping[int, VehicleDone],
    expected: Iterable[str] = (),
) -> BusDrops:
    """The readers' drops from their end-of-run reports, the supervisor's first, then the others by name; a reader
    in expected that sent none (a run that aborted before the broker reported, a broker killed by a fault, a vehicle
    that died) as None: its drops are unknown, not 0 (a new user read the missing broker's 10 as none)."""
    by_key: Counts = {}
    by_cause: Counts = {}
    if supervisor is not None:
        by_key[SUPERVISOR], by_cause[SUPERVISOR] = _sorted(supervisor.malformed), _sorted(supervisor.causes)
    others: dict[str, tuple[dict[str, int] | None, dict[str, int] | None]] = dict.fromkeys(expected, (None, None))
    if broker is not None:  # older logs: a total, not by key (a report of none has no keys either way)
        keys = dict(broker.by_key) if broker.by_key or not broker.malformed else {BY_NO_KEY: broker.malformed}
        others[BROKER] = keys, dict(broker.causes)
    for vid, done in vehicles.items():
        others[f"vehicle {vid}"] = dict(done.malformed), dict(done.causes)
    for reader in sorted(others):
        by_key[reader], by_cause[reader] = others[reader]
    return BusDrops(by_key, by_cause)


def bus_readers(vehicles: Iterable[int]) -> list[str]:
    """The readers of a Zenoh run's bus that report at its end, besides the supervisor: the broker, each vehicle."""
    return [BROKER, *(f"vehicle {vid}" for vid in vehicles)]


def _sorted(counts: Mapping[str, int]) -> dict[str, int]:
    return dict(sorted(counts.items()))

"""The state of the network over one sync step, as the supervisor's fault schedule sets it.

The graph in force (who hears whom), links that are down or degraded, a total blackout, silent modems. It travels in
every clock tick, so the broker only ever enforces what the supervisor says. `Network` is a msgspec Struct, the
message's only description (the tick's `network`: comms.records.tick); logs written before links were objects have
[sender, receiver] pairs and [sender, receiver, loss, delay] lists, which read the same (`from_older_log`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from functools import lru_cache

import msgspec

from comms.records.fields import Finite, Message, as_message, read_as_or_older
from comms.records.run import Edge, Link, links, older_links, pairs


class Impairment(msgspec.Struct, frozen=True):
    """What a fault does to one directed link: lose everything (with a reason), or add loss and delay."""

    lost: str | None = None
    extra_loss: float = 0.0
    extra_delay: float = 0.0


UNIMPAIRED, BLACKOUT, LINK_DOWN = Impairment(), Impairment("blackout"), Impairment("link_down")


class DegradedLink(msgspec.Struct, frozen=True, order=True):
    """A directed link a fault degrades: loss added (a probability) and delay added (s)."""

    sender: int
    receiver: int
    loss: Finite
    delay: Finite


class Network(msgspec.Struct, frozen=True):
    """The graph in force (`edges`, as vehicle-id pairs; its links as the message has them) and the link faults:
    links down, links degraded, a blackout, the silent modems. Built with `of` (sorted: two networks that act the
    same are equal)."""

    links: tuple[Link, ...] = msgspec.field(name="edges")
    down: tuple[Link, ...]
    degraded: tuple[DegradedLink, ...]
    blackout: bool
    silent: tuple[int, ...]

    @classmethod
    def of(
        cls,
        edges: Iterable[Edge],
        down: Iterable[Edge] = (),
        degraded: Mapping[Edge, tuple[float, float]] | None = None,
        blackout: bool = False,
        silent: Iterable[int] = (),
    ) -> Network:
        """degraded: (sender, receiver) -> (loss, delay)."""
        worse = tuple(DegradedLink(s, r, loss, delay) for (s, r), (loss, delay) in sorted((degraded or {}).items()))
        return cls(links(edges), links(sorted(set(down))), worse, blackout, tuple(sorted(set(silent))))

    @property
    def edges(self) -> tuple[Edge, ...]:
        return pairs(self.links)

    def neighbours(self, vehicle: int) -> list[int]:
        global _LAST
        last = _LAST  # one read: threads of a vehicle host ask too
        if last[0] is not self.links:  # the same graph is asked of by every vehicle in turn: no hash of its links
            last = _LAST = (self.links, _adjacency(self.links))
        return list(last[1].get(vehicle, ()))

    def impairment(self, sender: int, receiver: int) -> Impairment:
        # Asked per packet and link: the common answers are shared (frozen) records, not built anew.
        if self.blackout:
            return BLACKOUT
        if not (self.down or self.degraded):
            return UNIMPAIRED
        down, degraded = _faulty(self.down, self.degraded)
        if (sender, receiver) in down:
            return LINK_DOWN
        loss, delay = degraded.get((sender, receiver), (0.0, 0.0))
        return Impairment(None, loss, delay)

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object) -> Network:
        """The inverse of to_message, checked: ValueError naming the field for anything malformed."""
        return read_as_or_older(message, cls, from_older_log)


# The links last asked about (held, so no other tuple takes its id) and their adjacency: hashing a graph's links costs
# 15 us for a ring of 1000, asked of by every vehicle at every step.
_LAST: tuple[object, dict[int, tuple[int, ...]]] = ((), {})


@lru_cache(maxsize=256)
def _adjacency(edges: tuple[Link, ...]) -> dict[int, tuple[int, ...]]:
    """Every vehicle's neighbours in a graph, sorted: asked of every vehicle at every step (by the vehicle and the
    broker) of a graph that changes only with a fault, so worked out once per graph."""
    out: dict[int, set[int]] = {}
    for link in edges:
        i, j = link.sender, link.receiver
        out.setdefault(i, set()).add(j)
        out.setdefault(j, set()).add(i)
    return {v: tuple(sorted(js)) for v, js in out.items()}


@lru_cache(maxsize=256)
def _faulty(
    down: tuple[Link, ...], degraded: tuple[DegradedLink, ...]
) -> tuple[frozenset[Edge], dict[Edge, tuple[float, float]]]:
    """The links down and the degraded ones' (loss, delay), looked up per packet: worked out once per network."""
    return frozenset(pairs(down)), {(d.sender, d.receiver): (d.loss, d.delay) for d in degraded}


DEGRADED_NAMES = ("sender", "receiver", "loss", "delay")


def from_older_log(message: object) -> Message | None:
    """A network of a log from before links were objects, in today's form; None for anything else."""
    out = older_links(message, ("edges", "down"))
    degraded = message.get("degraded") if isinstance(message, dict) else None
    if isinstance(degraded, list) and degraded and all(isinstance(d, list) and len(d) == 4 for d in degraded):
        assert isinstance(message, dict)
        objects = [dict(zip(DEGRADED_NAMES, d, strict=True)) for d in degraded]
        out = {**(out or message), "degraded": objects}
    return out

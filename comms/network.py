"""The state of the network over one sync step, as the supervisor's fault schedule sets it.

The graph in force (who hears whom), links that are down or degraded, a total blackout, silent modems. It travels in
every clock tick, so the broker only ever enforces what the supervisor says.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from comms.fields import get, is_int, number


@dataclass(frozen=True, slots=True)
class Impairment:
    """What a fault does to one directed link: lose everything (with a reason), or add loss and delay."""

    lost: str | None = None
    extra_loss: float = 0.0
    extra_delay: float = 0.0


@dataclass(frozen=True, slots=True)
class Network:
    edges: tuple[tuple[int, int], ...]
    down: frozenset[tuple[int, int]] = frozenset()
    degraded: dict[tuple[int, int], tuple[float, float]] = field(default_factory=dict)  # (loss, delay)
    blackout: bool = False
    silent: frozenset[int] = frozenset()

    def neighbours(self, vehicle: int) -> list[int]:
        return list(_adjacency(self.edges).get(vehicle, ()))

    def impairment(self, sender: int, receiver: int) -> Impairment:
        if self.blackout:
            return Impairment("blackout")
        if (sender, receiver) in self.down:
            return Impairment("link_down")
        loss, delay = self.degraded.get((sender, receiver), (0.0, 0.0))
        return Impairment(None, loss, delay)

    def to_message(self) -> dict[str, Any]:
        """The wire form inside a tick (schema comms.schemas.TICK's network)."""
        return {
            "edges": [list(e) for e in self.edges],
            "down": [list(link) for link in sorted(self.down)],
            "degraded": [[s, r, loss, delay] for (s, r), (loss, delay) in sorted(self.degraded.items())],
            "blackout": self.blackout,
            "silent": sorted(self.silent),
        }

    @classmethod
    def from_message(cls, net: object) -> Network:
        """The inverse of to_message, checked: ValueError for anything malformed."""
        if not isinstance(net, dict):
            raise ValueError("field 'network' is not a map")
        edges = _pairs(net.get("edges"), 2, "edges")
        down = _pairs(net.get("down"), 2, "down")
        degraded = _pairs(net.get("degraded"), 4, "degraded")
        silent = net.get("silent")
        links = [pair[:2] for pair in edges + down + degraded]
        if not all(is_int(v) for pair in links for v in pair):
            raise ValueError("field 'network' has a link whose ends are not vehicle ids")
        if not isinstance(silent, list) or not all(is_int(v) for v in silent):
            raise ValueError("field 'silent' is not a list of vehicle ids")
        return cls(
            tuple((a, b) for a, b in edges),
            frozenset((a, b) for a, b in down),
            {(s, r): (number({"l": loss}, "l"), number({"d": delay}, "d")) for s, r, loss, delay in degraded},
            get(net, "blackout", bool),
            frozenset(silent),
        )


@lru_cache(maxsize=256)
def _adjacency(edges: tuple[tuple[int, int], ...]) -> dict[int, tuple[int, ...]]:
    """Every vehicle's neighbours in a graph, sorted: asked of every vehicle at every step (by the vehicle and the
    broker) of a graph that changes only with a fault, so worked out once per graph."""
    out: dict[int, set[int]] = {}
    for i, j in edges:
        out.setdefault(i, set()).add(j)
        out.setdefault(j, set()).add(i)
    return {v: tuple(sorted(js)) for v, js in out.items()}


def _pairs(items: object, width: int, name: str) -> list[list[Any]]:
    if not isinstance(items, list) or not all(isinstance(i, list) and len(i) == width for i in items):
        raise ValueError(f"field {name!r} is not a list of {width}-item lists")
    return items

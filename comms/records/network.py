"""The state of the network over one sync step, as the supervisor's fault schedule sets it.

The graph in force (who hears whom), links that are down or degraded, a total blackout, silent modems. It travels in
every clock tick, so the broker only ever enforces what the supervisor says.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from comms.records.fields import get, is_int, number
from comms.records.run import edges_of, link_of, links_message


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
        """The wire form inside a tick (schema comms.records.schemas.TICK's network)."""
        degraded = [{"sender": s, "receiver": r, "loss": loss, "delay": delay}
                    for (s, r), (loss, delay) in sorted(self.degraded.items())]  # fmt: skip
        return {"edges": links_message(self.edges), "down": links_message(sorted(self.down)), "degraded": degraded,
                "blackout": self.blackout, "silent": sorted(self.silent)}  # fmt: skip

    @classmethod
    def from_message(cls, net: object) -> Network:
        """The inverse of to_message, checked: ValueError for anything malformed."""
        if not isinstance(net, dict):
            raise ValueError("field 'network' is not a map")
        silent = net.get("silent")
        if not isinstance(silent, list) or not all(is_int(v) for v in silent):
            raise ValueError("field 'silent' is not a list of vehicle ids")
        degraded = dict(_degraded(item) for item in get(net, "degraded", list))
        return cls(edges_of(net, "edges"), frozenset(edges_of(net, "down")), degraded, get(net, "blackout", bool),
                   frozenset(silent))  # fmt: skip


@lru_cache(maxsize=256)
def _adjacency(edges: tuple[tuple[int, int], ...]) -> dict[int, tuple[int, ...]]:
    """Every vehicle's neighbours in a graph, sorted: asked of every vehicle at every step (by the vehicle and the
    broker) of a graph that changes only with a fault, so worked out once per graph."""
    out: dict[int, set[int]] = {}
    for i, j in edges:
        out.setdefault(i, set()).add(j)
        out.setdefault(j, set()).add(i)
    return {v: tuple(sorted(js)) for v, js in out.items()}


def _degraded(item: object) -> tuple[tuple[int, int], tuple[float, float]]:
    """A degraded link: {"sender", "receiver", "loss", "delay"}, or an older log's [sender, receiver, loss, delay]."""
    if isinstance(item, list) and len(item) == 4:
        item = dict(zip(("sender", "receiver", "loss", "delay"), item, strict=True))
    if not isinstance(item, dict):
        raise ValueError("field 'degraded' is not a list of degraded links")
    return link_of(item, "degraded"), (number(item, "loss"), number(item, "delay"))

"""The state of the network over one sync step, as the supervisor's fault schedule sets it.

The graph in force (who hears whom), links that are down or degraded, a total blackout, silent modems. It travels in
every clock tick, so the broker only ever enforces what the supervisor says.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


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
        out = {j for i, j in self.edges if i == vehicle} | {i for i, j in self.edges if j == vehicle}
        return sorted(out)

    def impairment(self, sender: int, receiver: int) -> Impairment:
        if self.blackout:
            return Impairment("blackout")
        if (sender, receiver) in self.down:
            return Impairment("link_down")
        loss, delay = self.degraded.get((sender, receiver), (0.0, 0.0))
        return Impairment(None, loss, delay)

    def message(self) -> dict[str, Any]:
        return {
            "edges": [list(e) for e in self.edges],
            "down": [list(link) for link in sorted(self.down)],
            "degraded": [[s, r, loss, delay] for (s, r), (loss, delay) in sorted(self.degraded.items())],
            "blackout": self.blackout,
            "silent": sorted(self.silent),
        }

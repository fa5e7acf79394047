"""The supervisor's own books of the links: every event of the run, whoever emitted it.

A broker that is killed cannot say what became of the packets it had in flight, and a restarted one starts its
statistics afresh; the supervisor's books see the whole run. They close the packets a dead broker left open as
`broker_down` (or `end_of_run`), so every link balances: sent = delivered + dropped.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable
from dataclasses import dataclass, field

from comms.broker.stats import LinkStats
from comms.records.messages import Message
from comms.records.records import LinkEvent


@dataclass
class LinkBooks:
    stats: LinkStats
    open: dict[tuple[int, int, int], float] = field(default_factory=dict)  # (sender, receiver, seq) -> sent at
    lambda2: list[Message] = field(default_factory=list)  # {"t", "lambda2"} per stats window, lambda2 >= 0
    _next_window: float | None = None

    def add(self, events: Iterable[LinkEvent]) -> None:
        events = events if isinstance(events, list) else list(events)  # read twice; the engine's are lists
        opened = self.open
        for e in events:
            key = (e.sender, e.receiver, e.seq)
            if e.kind == "sent":
                opened[key] = e.t
            else:
                opened.pop(key, None)
        self.stats.add(events)

    def close_open(self, t: float, reason: str) -> list[LinkEvent]:
        """The drops that close every packet still open (its broker is gone, or the run ended); add() them."""
        return [LinkEvent(t, s, r, seq, "dropped", reason=reason) for s, r, seq in sorted(self.open)]

    def window(self, t: float, alive: Collection[int] | None = None) -> None:
        """Call once per step, once every delivery up to t is booked: records the delivered graph's lambda_2 at
        every window boundary, over the stats' horizon (deliveries booked ahead of t do not count) and over the
        vehicles alive at every step of the window (alive: those at t; None: every vehicle)."""
        if alive is not None:
            self.stats.note_alive(alive)
        if self._next_window is None:
            self._next_window = self.stats.window
        if t + 1e-9 >= self._next_window:
            self.lambda2.append({"t": t, "lambda2": self.stats.delivered_connectivity(t, self.stats.window_alive())})
            self._next_window += self.stats.window

    @property
    def counts(self) -> dict[str, int]:
        return self.stats.totals()

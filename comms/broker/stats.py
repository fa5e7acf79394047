"""Per-directed-link statistics of a run, and the connectivity the channel actually delivered.

Fed with the channel's link events, it keeps per link: packets sent, delivered, dropped by cause, and the mean and
largest delay. Every window it computes lambda_2 of the undirected graph whose edges are the pairs that delivered at
least one packet (either way) within the last `horizon` s, over the vehicles alive at every step of the window (a
killed vehicle is not part of the fleet while it is down: counting it would say "disconnected" of survivors that still
hear each other, and one restarted at the window's end had no time to deliver): zero means the delivered graph was
disconnected. The horizon is the window unless the caller gives a longer one: a vehicle that transmits once a TDMA
frame longer than the window would otherwise leave its links out of most windows although they deliver every frame.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field

from comms.records.fields import Message
from comms.records.graph import algebraic_connectivity, laplacian
from comms.records.records import LinkEvent
from comms.records.reports import CommsStats, LinkCounts

CONNECTED = 1e-9  # lambda_2 at or below this is 0 (disconnected): eigvalsh gives +-1e-17 there, never less than 4/n^2


def clamp_lambda2(value: float) -> float:
    """lambda_2 with the rounding of a disconnected graph's (tiny, possibly negative) eigenvalue set to 0."""
    return value if value > CONNECTED else 0.0


@dataclass(slots=True)
class LinkBook:
    sent: int = 0
    delivered: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    delay_sum: float = 0.0
    delay_max: float = 0.0

    def counts(self, sender: int, receiver: int) -> LinkCounts:
        """The books as a snapshot has them; the delays only once a packet was delivered."""
        mean, most = (self.delay_sum / self.delivered, self.delay_max) if self.delivered else (None, None)
        return LinkCounts(sender, receiver, self.sent, self.delivered, dict(sorted(self.dropped.items())), mean, most)


class LinkStats:
    def __init__(self, vehicles: Sequence[int], window: float, horizon: float | None = None) -> None:
        self.vehicles = list(vehicles)
        self.window = window  # s between snapshots
        self.horizon = window if horizon is None else max(horizon, window)  # s a delivery keeps its pair connected
        self.books: dict[tuple[int, int], LinkBook] = {}
        self._recent: deque[tuple[float, int, int]] = deque()  # (arrival, sender, receiver) of deliveries
        self._throughout: frozenset[int] | None = None  # alive at every step noted since the last window's end
        self._latest: frozenset[int] | None = None

    def note_alive(self, alive: Collection[int]) -> None:
        """The vehicles alive at a step."""
        now = frozenset(alive)
        self._throughout = now if self._throughout is None else self._throughout & now
        self._latest = now

    def window_alive(self) -> frozenset[int] | None:
        """The vehicles alive at every step noted in the window now ending (None: none noted, every vehicle); the
        next window starts from those alive now."""
        alive, self._throughout = self._throughout, self._latest
        return alive

    def add(self, events: Iterable[LinkEvent]) -> None:
        # Every event of a run is booked here twice (the broker's books and the supervisor's): the link's counts are
        # kept in this loop, not by a call per event.
        books, recent = self.books, self._recent
        for event in events:
            key = (event.sender, event.receiver)
            book = books.get(key)
            if book is None:  # not setdefault: that built a LinkBook (and its Counter) for every event
                book = books[key] = LinkBook()
            kind = event.kind
            if kind == "sent":
                book.sent += 1
            elif kind == "delivered":
                book.delivered += 1
                delay = event.delay or 0.0
                book.delay_sum += delay
                if delay > book.delay_max:  # max(), without the call: the larger, the first when they are equal
                    book.delay_max = delay
                recent.append((event.t, *key))
            else:
                book.dropped[event.reason or "unknown"] += 1

    def delivered_connectivity(self, t: float, alive: Collection[int] | None = None) -> float:
        """lambda_2 (>= 0) of the graph of pairs that delivered in (t - horizon, t], over the vehicles alive at t
        (None: every vehicle)."""
        while self._recent and self._recent[0][0] <= t - self.horizon:
            self._recent.popleft()
        vehicles = self.vehicles if alive is None else [v for v in self.vehicles if v in alive]
        index = {v: i for i, v in enumerate(vehicles)}
        edges = {(index[s], index[r]) for at, s, r in self._recent if at <= t and s in index and r in index}
        return clamp_lambda2(algebraic_connectivity(laplacian(len(vehicles), edges)))

    def totals(self) -> dict[str, int]:
        """Packets sent, delivered and dropped over every link."""
        books = self.books.values()
        return {
            "sent": sum(b.sent for b in books),
            "delivered": sum(b.delivered for b in books),
            "dropped": sum(sum(b.dropped.values()) for b in books),
        }

    def snapshot(self, t: float, alive: Collection[int] | None = None) -> Message:
        """The message published on cpf/comms/stats: cumulative books per link, and lambda_2 now (over the horizon,
        over the vehicles alive; None: every vehicle)."""
        links = tuple(book.counts(s, r) for (s, r), book in sorted(self.books.items()))
        lambda2 = self.delivered_connectivity(t, alive)
        return CommsStats(t=t, window=self.window, horizon=self.horizon, lambda2=lambda2, links=links).to_message()

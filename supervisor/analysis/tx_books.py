"""Every transmission on the books (issue 30): per directed link, tx = sent + not_sent, each transmission a vehicle's
modem made counted on every link of the base graph and of the graph in force when it was made, as `sent` (the
channel's own event, with its fate: delivered or dropped) or as not sent with its cause:

- `sender_killed`: its sender was killed (or lost) before the broker took the step's transmissions in;
- `broker_down`: no broker was running when it was made (a restarted broker starts empty) or to take it in;
- `not_in_graph`: the graph in force then (a graph_switch) has no such link;
- `receiver_down`: the receiver was not running then (killed, lost, not yet restarted);
- `unaccounted`: none of these; a bug of the books, which tests hold at zero.

Read from the log alone (the tx, state, link-event, graph and fault records), so both engines, a recovered log and an
older log give the same books: the channel's records are not changed by them.
"""

from __future__ import annotations

from bisect import bisect_right
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from comms.records.events import EVENT_TOPICS, logged_events
from comms.records.messages import (
    FAULT_KEY,
    GRAPH_KEY,
    META_KEY,
    vehicle_of_key,
)

Edge = tuple[int, int]
_RUN_TOPICS = EVENT_TOPICS | {GRAPH_KEY, FAULT_KEY, META_KEY}  # the books' records but the vehicles'
CAUSES = ("sender_killed", "broker_down", "not_in_graph", "receiver_down", "unaccounted")


@dataclass
class TxBook:
    tx: int = 0
    sent: int = 0
    not_sent: Counter[str] = field(default_factory=Counter)

    def as_dict(self) -> dict[str, Any]:
        return {"tx": self.tx, "sent": self.sent, "not_sent": dict(sorted(self.not_sent.items()))}


@dataclass
class BooksLog:
    """What the books read from a log; also a reader of load_run's pass over it (supervisor.analysis.rundata's
    Collector: `cpf report` reads its log once)."""

    step: float = 1.0
    base: set[Edge] = field(default_factory=set)
    tx: list[tuple[int, int, float]] = field(default_factory=list)  # (sender, seq, t)
    alive: set[tuple[int, int]] = field(default_factory=set)  # (vehicle, step) with a state record
    sent: set[tuple[int, int, int]] = field(default_factory=set)  # (sender, receiver, seq)
    graphs: list[tuple[float, set[Edge]]] = field(default_factory=list)
    broker_down: list[tuple[str, float]] = field(default_factory=list)  # (phase, t) of broker_kill faults

    def take(self, topic: str, message: Any) -> None:
        owned = vehicle_of_key(topic)
        if owned is not None:
            vid, leaf = owned
            if leaf == "tx":
                self.tx.append((vid, int(message["seq"]), float(message["t"])))
            elif leaf == "state":
                self.alive.add((vid, self.index(float(message["t"]))))
        elif topic in EVENT_TOPICS:
            sent = [e for e in logged_events(topic, message) if e.get("kind") == "sent"]
            self.sent.update((int(e["sender"]), int(e["receiver"]), int(e["seq"])) for e in sent)
        elif topic == GRAPH_KEY:
            self.graphs.append((float(message["t"]), _directed(message["edges"])))
        elif topic == FAULT_KEY and message.get("kind") == "broker_kill":
            self.broker_down.append((str(message["phase"]), float(message["t"])))
        elif topic == META_KEY:
            self.step, self.base = float(message["step"]), _directed(message.get("links", message.get("edges", [])))

    def index(self, t: float) -> int:
        return round(t / self.step)

    def wanted(self, topic: str) -> bool:
        return _wanted(topic)

    def add(self, topic: str, message: Any) -> None:
        """take, with a record that does not read a ValueError (the Collector's contract: named and skipped)."""
        try:
            self.take(topic, message)
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"not a record the books can read ({type(exc).__name__}: {exc})") from None


def _directed(edges: Iterable[Any]) -> set[Edge]:
    pairs = [(int(e["sender"]), int(e["receiver"])) if isinstance(e, dict) else (int(e[0]), int(e[1])) for e in edges]
    return {p for i, j in pairs for p in ((i, j), (j, i))}


def _wanted(topic: str) -> bool:
    owned = vehicle_of_key(topic)
    return owned[1] in ("tx", "state") if owned is not None else topic in _RUN_TOPICS


def transmission_books(path: Path) -> dict[Edge, TxBook]:
    """(sender, receiver) -> its books, from the log at path (LogError if it is damaged)."""
    from supervisor.record.logfile import read_checked

    log = BooksLog()
    for topic, _, message in read_checked(path, _wanted):
        log.take(topic, message)
    return books_of(log)


def books_of(log: BooksLog) -> dict[Edge, TxBook]:
    books: dict[Edge, TxBook] = {}
    times = [t for t, _ in sorted(log.graphs, key=lambda g: g[0])]
    graphs = [g for _, g in sorted(log.graphs, key=lambda g: g[0])] or [log.base]
    for sender, seq, t in log.tx:
        in_force = graphs[max(0, bisect_right(times, t + 1e-9) - 1)]
        for receiver in sorted({j for i, j in log.base | in_force if i == sender}):
            book = books.setdefault((sender, receiver), TxBook())
            book.tx += 1
            if (sender, receiver, seq) in log.sent:
                book.sent += 1
            else:
                book.not_sent[_cause(log, sender, receiver, t, in_force)] += 1
    return dict(sorted(books.items()))


def _cause(log: BooksLog, sender: int, receiver: int, t: float, in_force: set[Edge]) -> str:
    """Why a transmission of t never entered the channel on sender -> receiver. The broker takes step k's
    transmissions in at step k + 1, with the kinematics of the vehicles running at both."""
    k = log.index(t)
    if (sender, k + 1) not in log.alive and any(step > k for _, step in log.alive):
        return "sender_killed"
    if _broker_down(log, t) or _broker_down(log, t + log.step):  # made while down, or taken in when it went down
        return "broker_down"
    if (sender, receiver) not in in_force:
        return "not_in_graph"
    if (receiver, k) not in log.alive or (receiver, k + 1) not in log.alive:
        return "receiver_down"
    return "unaccounted"


def _broker_down(log: BooksLog, t: float) -> bool:
    """Whether a broker_kill fault had stopped the broker at t (its start <= t < its end)."""
    down = False
    for phase, at in sorted(log.broker_down, key=lambda item: item[1]):
        if at > t + 1e-9:
            break
        down = phase == "start"
    return down


def balanced(books: dict[Edge, TxBook]) -> bool:
    return all(b.tx == b.sent + sum(b.not_sent.values()) for b in books.values())

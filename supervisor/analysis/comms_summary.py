"""The communication side of a run summary: what each directed link carried, lost and how late, how old the
neighbour estimates got, and how connected the delivered graph stayed.

The delivered graph at the end of each stats window holds the pairs that delivered a packet (either way) within the
last `horizon` s: the window, or 1.5 transmit intervals when a vehicle's schedule (its period held to its TDMA slot,
or its heartbeat; with TDMA a frame at least, whatever the policy) leaves longer between its packets
(supervisor.config.fleet.delivered_graph_horizon).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import msgspec

from comms.broker.stats import clamp_lambda2
from comms.records.reports import BY_NO_KEY, LinkCounts
from supervisor.analysis.condense import MAX_ROWS, SHOWN, delivered_share, first_looked_at, kept_note


@dataclass(frozen=True, slots=True)
class LinkRow:
    """A link's books (the broker's record of them: comms.records.reports.LinkCounts, field for field) and how old
    its receiver's estimate of the sender got."""

    sender: int
    receiver: int
    sent: int
    delivered: int
    dropped: dict[str, int]
    mean_delay: float | None
    max_delay: float | None
    mean_age: float | None  # of the receiver's estimate of the sender, s
    max_age: float | None


@dataclass(frozen=True, slots=True)
class CommsSummary:
    links: tuple[LinkRow, ...]
    lambda2_min: float | None  # of the delivered graph over the stats windows
    lambda2_mean: float | None
    windows: int
    window: float | None = None  # s between two lambda_2 values
    horizon: float | None = None  # s a delivery keeps its pair in the delivered graph

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def comms_summary(
    final: Mapping[str, Any] | None, history: Sequence[Mapping[str, Any]], ages: Mapping[tuple[int, int], list[float]]
) -> CommsSummary:
    """From the last cpf/comms/stats snapshot, all snapshots, and (sender, receiver) -> [sum, count, max] ages."""
    rows = []
    for link in final["links"] if final else []:
        books = LinkCounts.from_message(link)
        age = ages.get((books.sender, books.receiver))
        mean_age, max_age = (age[0] / age[1] if age[1] else None, age[2]) if age else (None, None)
        rows.append(LinkRow(**msgspec.structs.asdict(books), mean_age=mean_age, max_age=max_age))
    # The final snapshot's window may be partial; it still counts, it is what the end of the run delivered.
    lambdas = [clamp_lambda2(float(s["lambda2"])) for s in history]  # an older log may hold -1e-17 for 0
    window = float(final["window"]) if final and "window" in final else None
    horizon = float(final.get("horizon", window)) if final and window is not None else None
    return CommsSummary(
        tuple(rows),
        min(lambdas) if lambdas else None,
        sum(lambdas) / len(lambdas) if lambdas else None,
        len(lambdas),
        window,
        horizon,
    )


def format_comms(summary: CommsSummary) -> str:
    """A row per directed link; more than MAX_ROWS links: the SHOWN that delivered the smallest share of what they
    sent (supervisor.analysis.condense), then all of them added up."""
    rows, condensed = list(summary.links), len(summary.links) > MAX_ROWS
    if condensed:  # sorted is stable: ties in order
        rows = [*first_looked_at(rows, lambda r: delivered_share(r.sent, r.delivered)), _total(summary.links)]
    names = [f"{r.sender}->{r.receiver}" if r.sender else f"all {len(summary.links)}" for r in rows]
    width = max([8] + [len(name) + 1 for name in names])
    count = max([6] + [len(str(r.sent)) for r in rows]) + 1  # the total's counts too
    header = f"{'link':<{width}}{'sent':>{count}}{'deliv':>{count}}  {'dropped by cause':<34}"
    lines = [header + f"{'delay mean/max [s]':>20}{'age mean/max [s]':>19}"]
    for name, r in zip(names, rows, strict=True):
        causes = ", ".join(f"{n} {cause}" for cause, n in sorted(r.dropped.items())) or "-"
        lines.append(
            f"{name:<{width}}{r.sent:>{count}}{r.delivered:>{count}}  {causes:<34}"
            f"{_pair(r.mean_delay, r.max_delay):>20}{_pair(r.mean_age, r.max_age):>19}"
        )
    if condensed:
        lines.append(kept_note(SHOWN, len(summary.links), "links that delivered least, then all of them"))
    if (silent := _silent(summary.links)) is not None:
        lines.append(silent)
    if summary.lambda2_min is not None and summary.lambda2_mean is not None:
        lines.append(
            f"delivered-graph lambda_2 over {summary.windows} windows{_counted(summary)}: "
            f"min {summary.lambda2_min:.3f}, mean {summary.lambda2_mean:.3f} (0 = disconnected)"
        )
    return "\n".join(lines)


def _total(links: Sequence[LinkRow]) -> LinkRow:
    """Every link's books added up (sender 0: the row of all of them); means weighted by what each link delivered
    (delays) or by link (ages, which have no count here)."""
    dropped: dict[str, int] = {}
    for r in links:
        for cause, n in r.dropped.items():
            dropped[cause] = dropped.get(cause, 0) + n
    delays = [(r.mean_delay, r.delivered) for r in links if r.mean_delay is not None and r.delivered]
    ages = [r.mean_age for r in links if r.mean_age is not None]
    return LinkRow(
        0, 0, sum(r.sent for r in links), sum(r.delivered for r in links), dropped,
        sum(d * n for d, n in delays) / sum(n for _, n in delays) if delays else None,
        max((r.max_delay for r in links if r.max_delay is not None), default=None),
        sum(ages) / len(ages) if ages else None,
        max((r.max_age for r in links if r.max_age is not None), default=None),
    )  # fmt: skip


def _silent(links: Sequence[LinkRow]) -> str | None:
    """One line naming the links that carried packets and delivered none, with the cause of most of their losses
    (cpf validate says before a run which configurations can deliver nothing, and why)."""
    silent = [r for r in links if r.sent and not r.delivered]
    if not silent:
        return None
    causes: dict[str, int] = {}
    for r in silent:
        for cause, n in r.dropped.items():
            causes[cause] = causes.get(cause, 0) + n
    most = max(sorted(causes), key=lambda cause: causes[cause]) if causes else "none counted"
    names = ", ".join(f"{r.sender}->{r.receiver}" for r in silent)
    return (f"NOTHING DELIVERED on {len(silent)} of {len(links)} links ({names}), mostly lost to {most}: "
            f"their receivers coordinated without them (cpf validate says why before a run)")  # fmt: skip


def _counted(summary: CommsSummary) -> str:
    """What the delivered graph of a window holds."""
    window, horizon = summary.window, summary.horizon
    if window is None or horizon is None:
        return ""
    if horizon <= window:
        return f" of {window:g} s (pairs that delivered in the window)"
    return f" of {window:g} s (pairs that delivered in the last {horizon:g} s, 1.5 transmit intervals)"


def _pair(a: float | None, b: float | None) -> str:
    return "-" if a is None or b is None else f"{a:.2f} / {b:.2f}"


def format_malformed(
    counts: Mapping[str, Mapping[str, int] | None], causes: Mapping[str, Mapping[str, int] | None] | None = None
) -> str | None:
    """One line of the messages every reader of the bus counted and dropped (reader -> key -> count, and reader ->
    cause -> count; None: the reader sent no report), or None if none did: 'bus: N messages dropped (supervisor: 3
    on cpf/vehicle/2/state [2 replayed step, 1 too deep], broker: no report, ...)'."""
    total = sum(sum(by_key.values()) for by_key in counts.values() if by_key is not None)
    if not total:
        return None
    readers = []
    for reader, by_key in counts.items():
        if by_key is None:
            readers.append(f"{reader}: no report")
            continue
        keyed = [f"{n} on {key}" for key, n in sorted(by_key.items()) if n and key != BY_NO_KEY]
        why = [f"{n} {cause}" for cause, n in sorted(((causes or {}).get(reader) or {}).items()) if n]
        reasons = f" [{', '.join(why)}]" if why else ""
        readers.append(f"{reader}: {', '.join(keyed) if keyed else sum(by_key.values())}{reasons}")
    return f"bus: {total} message{'s' if total != 1 else ''} dropped ({', '.join(readers)})"

"""Lockstep time windows: how many steps the fleet may run without the bus (pure; supervisor.engine.clock asks, and
inside a span the broker: comms.broker.span).

Inside a window [a, b) nothing can cross the bus: no vehicle transmits before its last step b-1 (a transmission at
b-1 goes in the water at the next window's start, as a step's always does at the next tick), nothing external
changes at a+1 .. b-1 (faults, kills and restarts, graph switches: supervisor.plan.schedule.Schedule.next_change),
and b is at most the run's end. So the broker can hand out every reception of the window at its start and each
vehicle can step through it on its own; the results are those of stepping one step at a time.

Each vehicle says, with its state of step s, the first step n > s at which it may transmit next
(vehicles.transmission.earliest_transmission): a report (s, n). It may transmit at n, not before.

Inside a span the broker may run a window further, past transmissions, as far as the channel allows
(lookahead_end; comms.broker.lookahead says when and how the records stay those of stepping).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

Reports = Mapping[int, tuple[int, int]]  # vehicle -> (its latest step reported, the first step it may transmit at)


def report_of(s: int, next_tx: int | None) -> tuple[int, int]:
    """The report (s, n) of a vehicle's state of step s that says next_tx: n = next_tx if it is after s, else s + 1
    (one that says nothing, or nothing after s, may transmit at once)."""
    return s, next_tx if next_tx is not None and next_tx > s else s + 1


def window_end(a: int, change: int, alive: Sequence[int], reports: Reports, longest: int | None = None) -> int:
    """b of the window [a, b) granted now: its last step is the earliest at which a live vehicle may transmit, or
    the step before the next change (change: Schedule.next_change(a), at most the run's steps), and at least a. A
    vehicle that has not reported (none yet, or restarted) may transmit at once. longest: at most this many steps."""
    last = change - 1
    for v in alive:
        report = reports.get(v)
        last = min(last, report[1] if report is not None else a)
    end = max(a, last) + 1
    return end if longest is None else min(end, a + longest)


def lookahead_end(a: int, end: int, change: int, longest: int | None, quiet: int) -> int:
    """b of a window [a, b) that runs past its first transmission (channel lookahead), from the window [a, end) that
    stops at it (window_end: end - 1 is the earliest step n at which a vehicle may transmit, unless the change or
    longest cut it first). quiet: the first step after n whose intake a transmission made at n or later could
    change (comms.broker.lookahead.quiet_from). Inside [a, b) nothing sent from n on arrives, and nothing handed
    out at the window's start can be spoiled by it, so the broker may hand out every reception of the window at its
    start and put the window's transmissions in the water afterwards, step by step (comms.broker.lookahead): the
    records are those of stepping. Never shorter than end, never past change or longest."""
    b = min(change, quiet) if longest is None else min(change, quiet, a + longest)
    return max(end, b)


def worth_waiting(a: int, change: int, alive: Sequence[int], reports: Reports) -> bool:
    """Whether the window starting at a could be longer if granted once every state before a is in, rather than now
    (ahead, as the fleet still steps the window before; granting ahead saves a round trip through the supervisor).
    A vehicle whose bound is still to come (n >= a) keeps it; one that may transmit before a says nothing yet of
    after: if it transmitted at every step so far (n = s + 1) it likely will again, a window of one step either way;
    if it waits between transmissions (periodic, TDMA, a minimum interval) its fresh report is worth waiting for,
    unless a window of one step is all the others allow anyway."""
    bound, waits = change - 1, False
    for v in alive:
        report = reports.get(v)
        if report is None or report[1] == report[0] + 1:
            bound = min(bound, a)  # unknown, or transmitting at every step: it may transmit at a
        elif report[1] >= a:
            bound = min(bound, report[1])
        else:
            waits = True
    return waits and bound > a

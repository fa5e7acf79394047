"""Whether a fleet's graph is robust enough for W-MSR to withstand its lying vehicles, and the warning if not.

LeBlanc, Zhang, Koutsoukos & Sundaram, "Resilient asymptotic consensus in robust networks", IEEE JSAC 31(4), 2013:
a graph is (r, s)-robust if for every two disjoint non-empty sets of vehicles S1, S2, with X_S the vehicles of S
that have at least r neighbours outside S, all of S1 is in X_S1, or all of S2 is in X_S2, or |X_S1| + |X_S2| >= s;
r-robust is (r, 1)-robust. W-MSR with parameter F reaches consensus of the honest vehicles against at most F lying
ones in the whole fleet (the F-total malicious model: a liar tells every neighbour the same, as an acoustic broadcast
does) if and only if the graph is (F + 1, F + 1)-robust (their Theorem 1), and against at most F among each
vehicle's neighbours (F-local) if it is (2F + 1)-robust (Theorem 2; (F + 1)-robust is necessary). Below
(F + 1, F + 1), W-MSR can fail even with no liar at all: each vehicle also discards honest neighbours, and across a
cut it may keep none (tests/test_resilient.py: a ring of five with F = 1 and no liar stays 2.3 apart, as it
started).

Checked by enumerating the pairs of disjoint sets (3^n of them): up to MAX_VEHICLES vehicles; a larger fleet is
not checked (docs/resilience.md says so).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

from supervisor.config.scenario_schema import Scenario

MAX_VEHICLES = 12  # 3^12 pairs of sets, in numpy: ~0.1 s; beyond it the check is not made


def robust(n: int, edges: Sequence[tuple[int, int]], r: int, s: int = 1) -> bool:
    """Whether the undirected graph on vehicles 0..n-1 is (r, s)-robust."""
    neighbours = [0] * n
    for a, b in edges:
        neighbours[a] |= 1 << b
        neighbours[b] |= 1 << a
    bits = _bit_counts(n)
    sets = np.arange(1, 1 << n, dtype=np.int64)  # every non-empty set, as a bit mask
    reached = np.zeros(sets.shape, dtype=np.int64)  # |X_S|
    for v, mask in enumerate(neighbours):
        inside = (sets >> v) & 1
        outside = bits[np.int64(mask) & ~sets]  # < 2^n: the mask clears ~sets' high bits
        reached += inside * (outside >= r)
    size = bits[sets]
    short = (reached < size) & (reached < s)  # neither all of S reached, nor s reached by S alone
    candidates, counts = sets[short], reached[short]
    for one, count in zip(candidates.tolist(), counts.tolist(), strict=True):
        if np.any(((candidates & one) == 0) & (counts + count < s)):
            return False  # S1, S2 disjoint: neither wholly reached, and fewer than s reached by both
    return True


def _bit_counts(n: int) -> np.ndarray:
    """The number of bits set in each of 0 .. 2^n - 1 (numpy's bitwise_count is numpy 2's; we allow 1.26)."""
    counts = np.zeros(1 << n, dtype=np.int64)
    for bit in range(n):
        counts[1 << bit : 1 << (bit + 1)] = counts[: 1 << bit] + 1
    return counts


def resilience_warnings(sc: Scenario) -> Iterator[str]:
    """W-MSR on a graph not (F + 1, F + 1)-robust: consensus can fail with F liars anywhere, or none."""
    from supervisor.config.extensions import extension
    from vehicles.resilient import Wmsr

    co = sc.coordination
    try:  # the law as the run builds it: named any way, its f given or its own default
        law = extension("law", co.law, co.law_options)
    except (ValueError, TypeError):  # a law that does not build is scenario_checks' error, not this warning's
        return
    f = law.f if isinstance(law, Wmsr) else 0
    if f < 1:
        return
    ids = sc.vehicle_ids
    if len(ids) > MAX_VEHICLES:
        return
    index = {vid: i for i, vid in enumerate(ids)}
    edges = [(index[a], index[b]) for a, b in sc.graph.edges]
    if not robust(len(ids), edges, f + 1, f + 1):
        yield (
            f"coordination.law_options.f: the graph is not ({f + 1}, {f + 1})-robust, which W-MSR with f = {f} needs "
            f"to reach consensus against {f} lying vehicle{'s' if f > 1 else ''} (LeBlanc et al. 2013; "
            "docs/resilience.md): it may split the fleet, even with no liar (each vehicle also discards honest "
            f"neighbours); give more links or a smaller f, got {f}"
        )

"""Lockstep spans: the ticks the broker issues itself between the supervisor's grants (pure; comms.broker.broker asks).

Over a stretch of steps in which nothing external changes (no fault starts or ends, no process is killed or
restarted, the graph stays: supervisor.plan.schedule.Schedule.next_change), every tick is the first one's but for k
and t. So the supervisor grants the broker the whole stretch in one tick (its `span`) and the broker issues each
step's tick itself, in the batches message it sends anyway: no tick crosses the bus per step, and the supervisor only
records and watches. The broker works out each tick's time window (comms.broker.windows) when it issues it, from the
vehicles' reports of the step before (it holds them all then): the same rule as the supervisor's, on fresher facts.

A grant at a later step (the next stretch, sent ahead; or the same stretch again without a vehicle the supervisor
lost) governs from its own step on, or from the first step the broker has still to issue.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import msgspec

from comms.broker.windows import report_of, window_end
from comms.records.tick import Tick


@dataclass
class Grants:
    """The spans granted and not yet run through, and each vehicle's latest report (step, first step it may
    transmit at)."""

    dt: float
    grants: dict[int, Tick] = field(default_factory=dict)  # by first step
    reports: dict[int, tuple[int, int]] = field(default_factory=dict)

    def add(self, grant: Tick) -> None:
        self.grants[grant.k] = grant

    def report(self, vehicle: int, k: int, next_tx: int | None) -> None:
        """Vehicle's step message of step k (a window's last), which says when it may transmit next (None: at once)."""
        if vehicle not in self.reports or self.reports[vehicle][0] <= k:
            self.reports[vehicle] = report_of(k, next_tx)

    def governing(self, k: int) -> Tick | None:
        """The grant step k runs on: the latest granted at or before k whose span holds k."""
        starts = [start for start, grant in self.grants.items() if start <= k < grant.reach]
        return self.grants[max(starts)] if starts else None

    def tick(self, k: int, vehicles: list[int]) -> Tick | None:
        """The tick of step k, once every report of step k-1 is in (from the grant's live vehicles, all of vehicles
        if it does not say): its time window is as long as nothing can cross the bus (comms.broker.windows), up to the
        span's end; None if no grant holds k."""
        grant = self.governing(k)
        if grant is None:
            return None
        alive = grant.alive if grant.alive is not None else vehicles
        fresh = {v: r for v, r in self.reports.items() if r[0] == k - 1}  # a stale one may transmit at once
        end = window_end(k, grant.reach, alive, fresh, grant.longest)
        until = end if end > k + 1 else None
        t = grant.t if k == grant.k else k * self.dt
        return msgspec.structs.replace(
            grant, k=k, t=t, hold=grant.hold and end == grant.reach, until=until, span=None, longest=None
        )

    def forget_before(self, k: int) -> None:
        """Grants whose span ended before step k."""
        for start in [s for s, grant in self.grants.items() if grant.reach < k]:
            del self.grants[start]

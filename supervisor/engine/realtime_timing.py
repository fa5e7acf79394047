"""How well a realtime run kept to the wall clock: how late each reception was available to its vehicle against its
arrival, how many were taken in a step late (the only lateness that changes results), and how late the vehicles
began their steps. Fed with the vehicles' state and reception records, as the supervisor takes them in during a run
or as the realtime benchmark reads them back from a log."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, TypeGuard

import numpy as np

from comms.channel.channel import intake_step
from comms.records.messages import Message
from comms.records.receptions import RxBatch
from comms.records.state import StateReport


@dataclass
class RealtimeTiming:
    dt: float
    reached: list[float] = field(default_factory=list)  # s after each reception's arrival (negative: ahead)
    began: list[float] = field(default_factory=list)  # s after t_k that a vehicle began its step of t_k
    receptions: int = 0
    taken_late: int = 0

    def add(self, state: StateReport, batch: RxBatch | None) -> None:
        """A vehicle's step as the supervisor takes it in: its state and the reception batch it carries, if any."""
        self.add_state(state.to_message())
        if batch is not None:
            self.add_rx(batch.to_message())

    def add_state(self, state: Message) -> None:
        """A vehicle's state record; fields that are not numbers are left out (a malformed message never stops us)."""
        self.reached += [x for x in _list(state.get("rx_lateness")) if _number(x)]
        if _number(began := state.get("step_lateness")):
            self.began.append(float(began))

    def add_rx(self, rx: Message) -> None:
        """A vehicle's reception batch: which receptions it took in later than their arrival called for (a batch
        that does not parse is left out whole)."""
        try:
            batch = RxBatch.from_message(rx)
            timed = batch.timed()
        except ValueError:
            return
        self.receptions += len(timed)
        self.taken_late += sum(batch.k > intake_step(d.arrival, self.dt) for d, _ in timed)

    def as_dict(self) -> dict[str, Any]:
        """In ms: the delivery error max(0, reached - arrival) p50/p90/p99/max, how many came ahead, step starts."""
        reached = np.array(self.reached) * 1e3
        error = np.maximum(reached, 0.0)  # a reception that came ahead is held until its arrival: no error
        began = np.array(self.began) * 1e3
        some = len(error) > 0
        return {
            "deliveries": len(error),
            **{f"p{p}_ms": float(np.percentile(error, p)) if some else None for p in (50, 90, 99)},
            "max_ms": float(error.max()) if some else None,
            "ahead_share": float(np.mean(reached <= 0.0)) if some else None,
            "receptions": self.receptions,
            "taken_in_a_step_late": self.taken_late,
            "step_lateness_p50_ms": float(np.percentile(began, 50)) if len(began) else None,
            "step_lateness_p99_ms": float(np.percentile(began, 99)) if len(began) else None,
        }


def format_timing(timing: dict[str, Any]) -> str:
    """One line for the run summary."""
    if timing["deliveries"]:
        deliveries = (
            f"delivery error p50 {timing['p50_ms']:.2f} ms, p99 {timing['p99_ms']:.2f} ms, max {timing['max_ms']:.2f} "
            f"ms ({timing['ahead_share']:.0%} came ahead of their arrival)"
        )
    else:
        deliveries = "no deliveries"
    steps = (
        f"steps began {timing['step_lateness_p50_ms']:.2f} ms (p50) / {timing['step_lateness_p99_ms']:.2f} ms (p99) "
        "after their time"
        if timing["step_lateness_p50_ms"] is not None
        else "no steps"
    )
    late = f"{timing['taken_in_a_step_late']} of {timing['receptions']} receptions taken in a step late"
    return f"realtime: {deliveries}; {late}; {steps}"


def _list(value: object) -> list[Any]:
    return value if isinstance(value, list) else []


def _number(value: object) -> TypeGuard[float]:
    return isinstance(value, int | float) and not isinstance(value, bool) and bool(np.isfinite(value))


KEPT = 0.95  # of the speed asked: a realtime run below it fell behind the wall clock


def fell_behind(duration: float, stepping: float, speed: float) -> str | None:
    """A warning if a realtime run of duration simulated s, stepped in stepping wall s, ran slower than KEPT of the
    speed asked (a machine that cannot keep --speed 50 said nothing: a new user), else None."""
    achieved = duration / max(stepping, 1e-9)
    if achieved >= KEPT * speed:
        return None
    return (
        f"the run fell behind --speed {speed:g}: it ran at {achieved:.3g}x real time, the most this machine gave it "
        "(steps began late, and receptions may have been taken a step late)"
    )

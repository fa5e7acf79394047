"""Someone else's code, contained: a call that raises, or that overruns its CPU-time budget, becomes a
FloatingPointError whose message is one line naming the extension (its label, e.g. 'loss my_pkg:Fading').

FloatingPointError because that is what every engine and the command line already treat as a run-time failure of
the model (exit 1, one line), the same as a closed loop that diverged. Here for the lowest layer that runs
extensions (the channel's loss models); vehicles.guard builds its guard for laws, predictors and transmission
policies on the same call.

The budget is CPU time of the calling thread (time.thread_time), not wall time: a loaded machine does not make a
well-behaved extension overrun. Nor does the garbage collector: a full collection the call's allocations happen to
set off in a process with a large heap (a notebook's, a test worker's after hundreds of tests: 0.15-0.16 s, twice
in one day's suites) is the process's cost, not the extension's, and is not counted (_Collections).
"""

from __future__ import annotations

import gc
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from comms.channel.loss import LinkLoss

CALL_BUDGET = 0.1  # s of CPU per call: ~10^4 times what a law or a loss model of this kind needs
R = TypeVar("R")


class _Collections(threading.local):
    """CPU time this thread has spent in the garbage collector (gc.callbacks: a collection runs in the thread whose
    allocation set it off, and calls back there at its start and its stop)."""

    spent = 0.0
    began: float | None = None

    def __call__(self, phase: str, _info: dict[str, int]) -> None:
        if phase == "start":
            self.began = time.thread_time()
        elif self.began is not None:
            self.spent += time.thread_time() - self.began
            self.began = None


_COLLECTIONS = _Collections()
gc.callbacks.append(_COLLECTIONS)


def guarded_call(label: str, budget: float, method: Callable[..., R], *args: Any) -> R:
    """method(*args); FloatingPointError naming label if it raises or takes more than budget s of CPU (the garbage
    collector's time in it left out)."""
    start, collecting = time.thread_time(), _COLLECTIONS.spent
    try:
        value = method(*args)
    except (Exception, SystemExit) as exc:  # anything it raises (sys.exit too): its failure, named, not a traceback
        raise FloatingPointError(f"{label} raised {type(exc).__name__}: {short(exc)}") from None
    spent = time.thread_time() - start - (_COLLECTIONS.spent - collecting)
    if spent > budget:
        raise FloatingPointError(f"{label} took {spent:.3g} s of CPU in one call (budget {budget:g} s)")
    return value


def short(value: object) -> str:
    """A value for an error line: never its whole repr if that is long."""
    text = repr(value) if not isinstance(value, BaseException) else str(value)
    return text if len(text) <= 80 else text[:77] + "..."


@dataclass(frozen=True, slots=True)
class GuardedLoss:
    """Someone else's loss model (comms.channel.loss.LossModel) behind the guard; label: how an error names it
    ('loss my_pkg:Fading'). Each link it makes is guarded too: a decision that raises, overruns the budget or returns
    anything but None or a reason string ends the broker's run with one line naming it."""

    inner: Any
    label: str
    budget: float = CALL_BUDGET

    @property
    def draws(self) -> int:
        return _count(self.label, guarded_call(self.label, self.budget, lambda: self.inner.draws))

    def link(self) -> GuardedLink:
        made = guarded_call(self.label, self.budget, self.inner.link)
        if not isinstance(made, LinkLoss):
            raise FloatingPointError(f"{self.label} link() returned {short(made)}, not a link (draws and decide)")
        return GuardedLink(made, self.label, self.budget)


@dataclass(frozen=True, slots=True)
class GuardedLink:
    """One directed link of a guarded loss model."""

    inner: Any
    label: str
    budget: float

    @property
    def draws(self) -> int:
        return _count(self.label, guarded_call(self.label, self.budget, lambda: self.inner.draws))

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        try:
            reason = guarded_call(self.label, self.budget, self.inner.decide, rng, distance_m, size_bytes, t)
        except FloatingPointError as exc:  # when, in the run's time: the engines notice it a step apart
            raise FloatingPointError(f"{exc}, deciding a packet sent at t = {t:.1f} s") from None
        if reason is not None and not (isinstance(reason, str) and reason):  # "" would pass as delivered
            what = f"{self.label} returned {short(reason)}, not None or a reason string"
            raise FloatingPointError(f"{what}, for a packet sent at t = {t:.1f} s")
        return reason


def _count(label: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise FloatingPointError(f"{label} has draws = {short(value)}, not a count of random numbers")
    return value

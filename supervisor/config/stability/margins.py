"""Decay rate of the sampled coordination loop and the largest transmit period, delay and loss it tolerates.

The rate is -ln(rho) / P, rho the spectral radius of the monodromy over one period P without the consensus mode
(supervisor.config.stability.monodromy); with losses, -ln(rho_2) / (2 P), rho_2 that of the second-moment operator
(mean-square stability of the Markov jump linear system, Costa, Fragoso & Marques 2005, Thm. 3.9). Each margin is
found on the same model by a scan (doubling) for the first unstable value, then bisection; the loop is not known
to be monotone in any of them, so the margin is the first crossing the scan finds, not a proof of stability beyond.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from supervisor.config.stability.model import Loop, Sampling
from supervisor.config.stability.monodromy import Layout, monodromy, second_moment_radius, spectral_radius

MAX_STATES = 700  # a delay of many periods needs a buffer per period in flight: beyond this the scan stops
MAX_LOSS_STATES = 60  # the second-moment operator acts on N^2 numbers: beyond N = 60 losses are not analysed


@dataclass(frozen=True)
class Setting:
    """What the analysis needs: the loop, the period P (s; the TDMA frame), each sender's offset as a fraction of P,
    the delay d (s) and the i.i.d. loss probability p of every delivery; own_losses: (link, p) for the links (their
    index in loop.links) whose loss is their own, not p."""

    loop: Loop
    period: float
    delay: float
    phases: tuple[float, ...]
    loss: float = 0.0
    own_losses: tuple[tuple[int, float], ...] = ()

    def link_losses(self) -> list[float]:
        """Each link's loss probability, by its index in loop.links."""
        own = dict(self.own_losses)
        return [own.get(link, self.loss) for link in range(len(self.loop.links))]

    def lossy(self) -> bool:
        """Whether any link loses (a fleet loss every link replaces with its own loses nothing)."""
        return any(p > 0 for p in self.link_losses())

    def sampling(self) -> Sampling:
        return Sampling(self.period, self.delay, tuple(f * self.period for f in self.phases))

    def states(self) -> int:
        return Layout(self.loop, self.sampling()).size


def rate(setting: Setting) -> float:
    """Decay rate of the coordination error, 1/s (negative: it grows); mean-square with losses."""
    layout = Layout(setting.loop, setting.sampling())
    if setting.lossy() and layout.size <= MAX_LOSS_STATES:  # beyond: losses ignored (optimistic)
        rho2 = second_moment_radius(layout, setting.link_losses())
        return -math.log(max(rho2, 1e-300)) / (2 * setting.period)
    rho = spectral_radius(layout.reduced(monodromy(layout)))
    return -math.log(max(rho, 1e-300)) / setting.period


def converges(setting: Setting) -> bool:
    return rate(setting) > 0


def _first_failure(stable: Callable[[float], bool], start: float, limit: float) -> tuple[float, float] | None:
    """(last stable, first unstable) of start, 2 start, 4 start, ... up to limit; None if all are stable."""
    good, value = 0.0, start
    while value <= limit:
        if not stable(value):
            return good, value
        good, value = value, min(2 * value, limit) if value < limit else 2 * limit
    return None


def _bisect(stable: Callable[[float], bool], good: float, bad: float, tolerance: float) -> float:
    """The stability boundary between a stable and an unstable value, to within `tolerance` (relative)."""
    while bad - good > tolerance * bad:
        middle = (good + bad) / 2
        good, bad = (middle, bad) if stable(middle) else (good, middle)
    return (good + bad) / 2


def _margin(stable: Callable[[float], bool], start: float, limit: float, tolerance: float = 0.005) -> float | None:
    bracket = _first_failure(stable, start, limit)
    return None if bracket is None else _bisect(stable, *bracket, tolerance)


PERIOD_REACH = 200.0  # s: the longest period largest_period tries, or the setting's own if longer


def largest_period(setting: Setting, limit: float = PERIOD_REACH) -> float | None:
    """The largest transmit period (TDMA frame) that converges, s; None: converges up to limit (or the setting's
    own period, if longer: from a period of 500 s the scan tried nothing and said 'any length up to 200 s')."""
    return _margin(lambda p: converges(replace(setting, period=p)), setting.period, max(limit, setting.period))


def delay_reach(setting: Setting, limit: float = 200.0) -> float:
    """The longest delay the scan tries, s: limit, or less where the buffers would pass MAX_STATES states."""
    n = setting.loop.n
    return min(limit, setting.period * (MAX_STATES - 2 * n) / (2 * n) - setting.period)


def largest_delay(setting: Setting, limit: float = 200.0) -> float | None:
    """The largest delay that converges, s; None: converges up to limit or MAX_STATES states."""
    if not converges(setting):
        return 0.0
    within = delay_reach(setting, limit)
    stable = lambda d: converges(replace(setting, delay=d))  # noqa: E731
    return _margin(stable, max(setting.delay, setting.period), within, tolerance=0.01)


def largest_loss(setting: Setting) -> float | None:
    """The largest i.i.d. loss probability of the links that have none of their own (comms.loss; those that have
    keep theirs, a link with only its own burst at its long-run loss with the scenario's comms.loss: held, not
    scanned) under which the loop stays mean-square stable; None: any below 1; NaN: not analysed (more than
    MAX_LOSS_STATES states)."""
    if setting.states() > MAX_LOSS_STATES:
        return math.nan
    if not converges(replace(setting, loss=0.0)):
        return 0.0
    stable = lambda p: converges(replace(setting, loss=p))  # noqa: E731
    good = 0.0
    for p in (0.5, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995, 0.999):
        if not stable(p):
            return _bisect(stable, good, p, 0.003)
        good = p
    return None

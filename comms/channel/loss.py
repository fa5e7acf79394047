"""Packet loss models for one directed acoustic link: composable and deterministic given a numpy Generator.

Sources: shared/reference/acoustics.md ("Loss models").
- Bernoulli: independent loss, as MOOS-IvP's uFldNodeComms (uniform drop percentage).
- Gilbert-Elliott: two-state Markov chain, p = P(good -> bad), r = P(bad -> good); long-run share of bad packets
  p / (p + r), mean bad run 1 / r packets (tc netem's "loss gemodel p r 1-h 1-k").
- Time-based Gilbert-Elliott: the same two states as a continuous-time Markov chain with mean bad (burst) duration
  in seconds, stepped by the time since the link's last packet: bursts last seconds whatever the packet rate.
- Link budget: packet error rate from comms.channel.acoustics (Thorp absorption, Coates noise, BPSK/FSK bit errors),
with
  shadowing and fading (comms.channel.link_budget, comms.channel.fading).
- Range table: success probability vs range, as GobySoft/netsim's range_to_packet_success.
Distances in m, sizes in bytes, probabilities in [0, 1].

A model (frozen, validated configuration) makes a fresh `LinkLoss` per directed link with `link()`; a `LinkLoss`
draws exactly `draws` uniforms per decision whatever the outcome, so random streams stay aligned across runs that
differ only in what gets lost. These are the built-ins of the entry-point group cpf.loss (pyproject.toml); a
scenario names any model of that interface (LossModel) by `comms.loss_model`, found and checked as the other
extensions are (supervisor.config.extensions), and someone else's runs behind comms.channel.guard.GuardedLoss.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from comms.channel.link_budget import LinkBudgetRange
from numerics import exp

__all__ = [
    "Bernoulli",
    "Composite",
    "GilbertElliott",
    "GilbertElliottTime",
    "LinkBudgetRange",
    "LinkLoss",
    "LossModel",
    "RangeTable",
]


@runtime_checkable
class LinkLoss(Protocol):
    """The loss model's state on one directed link (sender -> receiver): what it remembers from packet to packet
    (a Gilbert-Elliott chain's state, a shadowing level). A stateless model may be its own LinkLoss."""

    @property
    def draws(self) -> int:
        """Uniform random numbers decide consumes per packet: the same count whatever it decides."""
        ...

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        """Whether this packet is lost on this link, and why.

        rng: the link's own random stream (seeded from the run's seed, sender and receiver); draw exactly
        self.draws numbers from it (rng.random()) whatever the outcome, so the streams of runs that differ only in
        what gets lost stay aligned.
        distance_m: the path the packet travels, sender at transmission to receiver at arrival, m (time of flight
        x sound speed).
        size_bytes: the packet's size on air, B.
        t: its transmission time, s (a link's packets come in time order).
        Returns None (not lost) or why it is lost: a short word the link statistics count it under ("loss",
        "burst", "range", ...).
        """
        ...


@runtime_checkable
class LossModel(Protocol):
    """A packet-loss model of the acoustic channel (interface of the entry-point group cpf.loss): frozen
    configuration, its fields its options; the same for every directed link, each of which gets its own state."""

    @property
    def draws(self) -> int:
        """Random numbers consumed per decision by each of its links."""
        ...

    def link(self) -> LinkLoss:
        """Fresh state for one directed link, at the start of the run (and when a restarted broker starts anew)."""
        ...


def _check(ok: bool, name: str, value: object, what: str) -> None:
    if not ok:
        raise ValueError(f"{name} must be {what}, got {value!r}")


def _is_probability(x: float) -> bool:
    return 0.0 <= x <= 1.0  # False for NaN


@dataclass(frozen=True, slots=True)
class Bernoulli:
    """Each packet lost independently with probability p. Stateless: it is its own LinkLoss."""

    p: float

    def __post_init__(self) -> None:
        _check(_is_probability(self.p), "p", self.p, "in [0, 1]")

    @property
    def draws(self) -> int:
        return 1

    def link(self) -> Bernoulli:
        return self

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        return "loss" if rng.random() < self.p else None


@dataclass(frozen=True, slots=True)
class GilbertElliott:
    """Bursty loss: a two-state (good/bad) Markov chain stepped once per packet on the link.

    mean_loss L and mean_burst B (packets) define the chain: r = 1 / B, p = L r / (1 - L), so that the long-run
    share of bad packets is p / (p + r) = L and a bad run lasts 1 / r = B packets on average. With the defaults
    (good_loss 0 = 1 - k, bad_loss 1 = 1 - h) every bad packet and only those are lost, so L is the long-run loss
    rate and B the mean length of a run of consecutive losses. Other good_loss / bad_loss values are applied on top
    of the same chain: the long-run loss is then `loss_rate` = (1 - L) good_loss + L bad_loss.
    The first packet's state is drawn from the stationary distribution, so short runs are unbiased.
    """

    mean_loss: float
    mean_burst: float
    good_loss: float = 0.0
    bad_loss: float = 1.0

    def __post_init__(self) -> None:
        _check(0.0 <= self.mean_loss < 1.0, "mean_loss", self.mean_loss, "in [0, 1)")
        _check(self.mean_burst >= 1.0 and math.isfinite(self.mean_burst), "mean_burst", self.mean_burst, ">= 1")
        # p <= 1 <=> L <= B / (B + 1): a short burst cannot make up a large loss rate.
        limit = self.mean_burst / (self.mean_burst + 1.0)
        _check(self.mean_loss <= limit, "mean_loss", self.mean_loss, f"<= mean_burst / (mean_burst + 1) = {limit:g}")
        _check(_is_probability(self.good_loss), "good_loss", self.good_loss, "in [0, 1]")
        _check(_is_probability(self.bad_loss), "bad_loss", self.bad_loss, "in [0, 1]")

    @property
    def r(self) -> float:
        """P(bad -> good) per packet."""
        return 1.0 / self.mean_burst

    @property
    def p(self) -> float:
        """P(good -> bad) per packet."""
        return self.mean_loss * self.r / (1.0 - self.mean_loss)

    @property
    def loss_rate(self) -> float:
        """Long-run packet loss probability, good_loss and bad_loss included."""
        return (1.0 - self.mean_loss) * self.good_loss + self.mean_loss * self.bad_loss

    @property
    def draws(self) -> int:
        return 2

    def link(self) -> ChainLink:
        return ChainLink(self)

    def next_bad(self, bad: bool, step: float, elapsed: float) -> bool:
        return not step < self.r if bad else step < self.p


class _Chain(Protocol):
    """A good/bad chain: its long-run share of bad packets and its step from one packet to the next."""

    @property
    def mean_loss(self) -> float: ...
    @property
    def good_loss(self) -> float: ...
    @property
    def bad_loss(self) -> float: ...

    def next_bad(self, bad: bool, step: float, elapsed: float) -> bool:
        """The state at this packet from the state at the link's last one, a uniform step and the time since (s)."""
        ...


@dataclass(slots=True)
class ChainLink:
    """A good/bad chain's state on one directed link at its last packet (None until the first), for both the
    per-packet and the time-based Gilbert-Elliott models: they differ only in how the chain steps (next_bad)."""

    model: _Chain
    bad: bool | None = field(default=None)
    last_t: float = 0.0

    @property
    def draws(self) -> int:
        return 2

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        step, lose = rng.random(2)
        m = self.model
        if self.bad is None:
            self.bad = bool(step < m.mean_loss)  # stationary start: P(bad) = mean_loss
        else:
            self.bad = m.next_bad(self.bad, float(step), max(t - self.last_t, 0.0))
        self.last_t = t
        return "burst" if lose < (m.bad_loss if self.bad else m.good_loss) else None


@dataclass(frozen=True, slots=True)
class GilbertElliottTime:
    """Bursty loss in time: the good/bad chain in continuous time, with a mean bad (burst) duration in seconds.

    Rates per second: bad -> good mu = 1 / mean_duration, good -> bad lambda = mean_loss mu / (1 - mean_loss), so the
    long-run share of time in the bad state is lambda / (lambda + mu) = mean_loss and a bad spell lasts mean_duration
    s on average. Between two packets dt apart the chain moves with P(bad | bad) = L + (1 - L) e^{-(lambda + mu) dt},
    P(bad | good) = L (1 - e^{-(lambda + mu) dt}) (the two-state chain's transition function), so a burst lasts
    seconds whether packets come every 0.1 s or every minute. good_loss, bad_loss as in GilbertElliott.
    """

    mean_loss: float
    mean_duration: float
    good_loss: float = 0.0
    bad_loss: float = 1.0

    def __post_init__(self) -> None:
        _check(0.0 <= self.mean_loss < 1.0, "mean_loss", self.mean_loss, "in [0, 1)")
        _check(0.0 < self.mean_duration < math.inf, "mean_duration", self.mean_duration, "> 0 and finite")
        _check(_is_probability(self.good_loss), "good_loss", self.good_loss, "in [0, 1]")
        _check(_is_probability(self.bad_loss), "bad_loss", self.bad_loss, "in [0, 1]")

    @property
    def rate(self) -> float:
        """lambda + mu, 1/s: how fast the chain forgets its state."""
        return 1.0 / (self.mean_duration * (1.0 - self.mean_loss))

    @property
    def draws(self) -> int:
        return 2

    def link(self) -> ChainLink:
        return ChainLink(self)

    def next_bad(self, bad: bool, step: float, elapsed: float) -> bool:
        memory = exp(-self.rate * elapsed)
        return step < (self.mean_loss + (1.0 - self.mean_loss) * memory if bad else self.mean_loss * (1.0 - memory))


@dataclass(frozen=True, slots=True)
class RangeTable:
    """Success probability linearly interpolated in range between table points, constant beyond the ends."""

    ranges_m: tuple[float, ...]
    success: tuple[float, ...]

    def __post_init__(self) -> None:
        _check(len(self.ranges_m) >= 1, "ranges_m", self.ranges_m, "non-empty")
        _check(len(self.success) == len(self.ranges_m), "success", self.success, "as long as ranges_m")
        _check(all(math.isfinite(x) for x in self.ranges_m), "ranges_m", self.ranges_m, "finite")
        increasing = all(a < b for a, b in pairwise(self.ranges_m))
        _check(increasing, "ranges_m", self.ranges_m, "strictly increasing")
        _check(all(_is_probability(s) for s in self.success), "success", self.success, "in [0, 1]")

    def success_probability(self, distance_m: float) -> float:
        return float(np.interp(distance_m, self.ranges_m, self.success))

    @property
    def draws(self) -> int:
        return 1

    def link(self) -> RangeTable:
        return self

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        u = rng.random()
        return "range" if u >= self.success_probability(distance_m) else None


@dataclass(frozen=True, slots=True)
class Composite:
    """Lost if any model says so, with the reason of the first that does; an empty Composite never loses.

    Every model decides every packet, so each one's draws and state (a Gilbert-Elliott chain) advance the same
    whatever the others decide.
    """

    # Its option is models already built (by the scenario's keys): not an option a scenario file can give.
    __pydantic_config__: ClassVar[dict[str, Any]] = {"arbitrary_types_allowed": True}

    models: tuple[LossModel, ...]

    def __post_init__(self) -> None:
        _check(isinstance(self.models, tuple), "models", self.models, "a tuple")
        for m in self.models:
            _check(hasattr(m, "link") and hasattr(m, "draws"), "models", m, "loss models (with link and draws)")

    @property
    def draws(self) -> int:
        return sum(m.draws for m in self.models)

    def link(self) -> CompositeLink:
        return CompositeLink(tuple(m.link() for m in self.models))


@dataclass(frozen=True, slots=True)
class CompositeLink:
    links: tuple[LinkLoss, ...]

    @property
    def draws(self) -> int:
        return sum(k.draws for k in self.links)

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        reasons = [k.decide(rng, distance_m, size_bytes, t) for k in self.links]  # all of them: no short-circuit
        return next((r for r in reasons if r is not None), None)

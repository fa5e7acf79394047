"""Loss models for tests/test_loss_extension.py: one that works, and one of each way a loss model can break."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Annotated

import numpy as np
from annotated_types import Ge, Gt, Le


@dataclass(frozen=True)
class Cutoff:
    """Every packet past max_range m is lost ("range"); nearer ones with probability p ("noise"). Stateless."""

    max_range: Annotated[float, Gt(0)] = 40.0
    p: Annotated[float, Ge(0), Le(1)] = 0.1

    @property
    def draws(self) -> int:
        return 1

    def link(self) -> Cutoff:
        return self

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        u = rng.random()  # drawn whatever the outcome: the link's stream stays aligned
        if distance_m > self.max_range:
            return "range"
        return "noise" if u < self.p else None


@dataclass(frozen=True)
class NoLink:
    """Has no link method: not a loss model."""

    @property
    def draws(self) -> int:
        return 1


@dataclass(frozen=True)
class _Breaks:
    """Decides well until its packets' time passes after s, then breaks in its subclass's way."""

    after: float = 2.0

    @property
    def draws(self) -> int:
        return 1

    def link(self) -> _Breaks:
        return self

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        rng.random()
        return self.broken() if t > self.after else None

    def broken(self) -> str | None:
        return None


@dataclass(frozen=True)
class Raises(_Breaks):
    def broken(self) -> str | None:
        return str(1 / 0)


@dataclass(frozen=True)
class ReturnsNumber(_Breaks):
    def broken(self) -> str | None:
        return 1  # type: ignore[return-value]  # the mistake under test


@dataclass(frozen=True)
class Slow(_Breaks):
    """Burns 0.3 s of CPU in one decision."""

    def broken(self) -> str | None:
        end = time.thread_time() + 0.3
        while time.thread_time() < end:
            pass
        return None


@dataclass(frozen=True)
class NegativeDraws(Cutoff):
    """Says it draws -1 numbers a decision: not a count."""

    @property
    def draws(self) -> int:
        return -1


@dataclass(frozen=True)
class DrawsRaises(Cutoff):
    """Its draws property raises."""

    @property
    def draws(self) -> int:
        raise RuntimeError("draws boom")

"""Coordination laws for tests/test_extensions.py: one that works, and one of each way an extension can break; and a
predictor of a user's own."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated

from annotated_types import Gt

from vehicles.coordination import CoordinationGains
from vehicles.estimates import NeighbourEstimate


@dataclass(frozen=True)
class Damped:
    """Law (5) without its neighbour-rate term: v_tilde = -k2 (gamma_dot - v_r + gain sum_j (gamma_i - gamma_j))."""

    gain: Annotated[float, Gt(0)] = 0.2

    def correction(
        self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
    ) -> float:
        disagreement = sum(gamma - gamma_j for gamma_j, _ in neighbours)
        return -gains.k2 * (gamma_dot - gains.v_r + self.gain * disagreement)


@dataclass(frozen=True)
class Halfway:
    """A predictor between first_order and reference: the neighbour's gamma advances at the mean of its last rate and
    v_r (vehicles.estimates.Predictor)."""

    def predict(self, estimate: NeighbourEstimate, t: float, v_r: float) -> tuple[float, float]:
        rate = (estimate.gamma_dot + v_r) / 2
        return estimate.gamma + rate * (t - estimate.stamp), estimate.gamma_dot


@dataclass(frozen=True)
class NoCorrection:
    """Has no correction method: not a law."""

    def predict(self) -> float:
        return 0.0


@dataclass(frozen=True)
class Raises:
    """Fails once the run is under way (after = s)."""

    after: float = 1.0

    def correction(self, gamma: float, gamma_dot: float, neighbours: object, gains: CoordinationGains) -> float:
        if gamma > self.after:
            return 1.0 / 0.0
        return 0.0


@dataclass(frozen=True)
class NotFinite:
    def correction(self, gamma: float, gamma_dot: float, neighbours: object, gains: CoordinationGains) -> float:
        return float("nan") if gamma > 1.0 else 0.0


@dataclass(frozen=True)
class Slow:
    """Burns 0.3 s of CPU in one call once gamma passes 1."""

    def correction(self, gamma: float, gamma_dot: float, neighbours: object, gains: CoordinationGains) -> float:
        if gamma > 1.0:
            end = time.thread_time() + 0.3
            while time.thread_time() < end:
                pass
        return 0.0


@dataclass(frozen=True)
class LiesAbove:
    """A vehicle that lies once its gamma passes `gamma`: its law asks for a rate of 1e6 (finite, so no guard of
    its own stops it), its state then carries a gamma and gamma_dot far beyond what its vehicle can do. In the
    paper scenario vehicle 2 starts ahead (gamma ~132 against ~82 and ~93), so it alone passes 133 in its first 20 s."""

    gamma: float = 133.0

    def correction(self, gamma: float, gamma_dot: float, neighbours: object, gains: CoordinationGains) -> float:
        return 1e6 if gamma > self.gamma else 0.0


def _made() -> type:
    """A law class made by a function: it runs in process, but no other process can import it by its name."""

    @dataclass(frozen=True)
    class Made:
        def correction(
            self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
        ) -> float:
            return -gains.k2 * (gamma_dot - gains.v_r)

    return Made


Made = _made()


@dataclass(frozen=True)
class Every:
    """A trigger of a user's: a message every `period` s (tests/test_feasibility.py)."""

    period: Annotated[float, Gt(0)] = 4.0

    def due(self, t: float, dt: float, now: NeighbourEstimate, last: NeighbourEstimate | None) -> bool:
        return last is None or t - last.stamp >= self.period - dt / 2

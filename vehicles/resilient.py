"""W-MSR: law (5) made resilient to neighbours that lie (LeBlanc, Zhang, Koutsoukos & Sundaram, "Resilient asymptotic
consensus in robust networks", IEEE JSAC 31(4), 2013).

Each vehicle sorts what it holds of its neighbours by their gamma_j against its own gamma_i, and discards up to F of
them above its own (the F largest, or all above if fewer) and up to F below (the F smallest, or all below if fewer);
law (5), corrected, then runs on the neighbours it kept, their gamma_dot_j with them. A neighbour whose value stays
within the range of the honest ones does no harm; one outside it is discarded. The fleet reaches consensus with up to
F such vehicles in all if and only if the graph is (F + 1, F + 1)-robust, and with up to F among each vehicle's
neighbours if it is (2F + 1)-robust (docs/resilience.md, supervisor/config/robustness.py): with F = 1 a ring or a
tree never qualifies. `f = 0` is law (5) itself.

Registered under `cpf.coordination` as `wmsr` (coordination.law = "wmsr", coordination.law_options = { f = 1 }); to
study it, a `gamma_offset` fault makes a vehicle broadcast a gamma it does not have.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated

from annotated_types import Ge, Le

from vehicles.coordination import CoordinationGains, law5


def kept(gamma: float, neighbours: Sequence[tuple[float, float]], f: int) -> list[tuple[float, float]]:
    """The neighbours W-MSR keeps: up to f of the largest gamma_j above gamma and up to f of the smallest below it
    discarded (ties broken by position in the list, so the result does not depend on float comparisons of equals)."""
    order = sorted(range(len(neighbours)), key=lambda n: (neighbours[n][0], n))
    above = [n for n in order if neighbours[n][0] > gamma]
    below = [n for n in order if neighbours[n][0] < gamma]
    dropped = set(above[len(above) - min(f, len(above)) :]) | set(below[: min(f, len(below))])
    return [value for n, value in enumerate(neighbours) if n not in dropped]


@dataclass(frozen=True, slots=True)
class Wmsr:
    """Law (5), corrected, over the neighbours W-MSR keeps; f: how many lying neighbours each vehicle withstands
    (the graph must be (f + 1, f + 1)-robust; docs/resilience.md)."""

    f: Annotated[int, Ge(0), Le(10)] = 1

    def correction(
        self, gamma: float, gamma_dot: float, neighbours: Sequence[tuple[float, float]], gains: CoordinationGains
    ) -> float:
        return law5(gamma, gamma_dot, kept(gamma, neighbours, self.f), gains, False)

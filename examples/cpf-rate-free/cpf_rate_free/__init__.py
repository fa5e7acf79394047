"""Law (5) without its neighbour-rate term: a stale gamma_dot of a neighbour never enters the law."""

from dataclasses import dataclass
from typing import Annotated

from annotated_types import Gt


@dataclass(frozen=True)
class RateFree:
    """v_tilde_i = -k2 (gamma_dot_i - v_r + gain * sum_j (gamma_i - gamma_j)); gain in 1/s."""

    gain: Annotated[float, Gt(0)] = 0.2

    def correction(self, gamma, gamma_dot, neighbours, gains):
        disagreement = 0.0
        for gamma_j, _ in neighbours:
            disagreement += gamma - gamma_j
        return -gains.k2 * (gamma_dot - gains.v_r + self.gain * disagreement)

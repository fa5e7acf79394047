"""What a vehicle holds of a neighbour between messages, and how it predicts it forward.

A message carries the sender's (gamma, gamma_dot) stamped with its simulation time. Between messages the receiver
predicts the neighbour's gamma:
- first_order: gamma + gamma_dot (t - stamp)   (default: exact for a neighbour moving at constant rate)
- hold:        gamma                             (zero-order hold)
- reference:   gamma + v_r (t - stamp)           (the open-loop predictor of logic-based communication)
A message takes effect no earlier than its arrival; a message older than the one held is ignored.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Predictor = Literal["first_order", "hold", "reference"]


@dataclass(frozen=True, slots=True)
class NeighbourEstimate:
    gamma: float
    gamma_dot: float
    stamp: float  # sender's simulation time of the data, s


def predict(estimate: NeighbourEstimate, t: float, predictor: Predictor, v_r: float) -> tuple[float, float]:
    """(gamma_hat, gamma_dot_hat) of the neighbour at time t."""
    age = t - estimate.stamp
    if predictor == "first_order":
        return estimate.gamma + estimate.gamma_dot * age, estimate.gamma_dot
    if predictor == "reference":
        return estimate.gamma + v_r * age, estimate.gamma_dot
    return estimate.gamma, estimate.gamma_dot


def newer(held: NeighbourEstimate | None, incoming: NeighbourEstimate) -> bool:
    """Whether an incoming estimate should replace the held one (late, reordered packets must not go back)."""
    return held is None or incoming.stamp > held.stamp

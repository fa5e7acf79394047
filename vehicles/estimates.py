"""What a vehicle holds of a neighbour between messages, and how it predicts it forward: the predictor interface.

A message carries the sender's (gamma, gamma_dot) stamped with its simulation time. Between messages the receiver
predicts the neighbour with a `Predictor`: any object with `predict(estimate, t, v_r) -> (gamma_hat,
gamma_dot_hat)`, pure (the same answer for the same arguments: it runs at every RK4 stage, in every engine, and in
re-simulation). The built-ins are registered under the entry-point group `cpf.predictors` like any extension
(docs/extending.md):
- `first_order`: gamma + gamma_dot age, the extrapolation of law (5)'s analysis (exact for a neighbour moving at a
  constant rate); with `horizon` H, the extrapolation stops after H s (gamma + gamma_dot min(age, H)), so a stale
  rate is not carried over a long silence;
- `hold`: gamma (zero-order hold);
- `reference`: gamma + v_r age, the open-loop predictor of logic-based communication (Rego, Hung, Jones, Pascoal &
  Aguiar, "Cooperative path-following control with logic-based communications: theory and practice", IET 2019,
  sec. 3: each vehicle runs a copy of its neighbours' estimators driven by the reference speed; Aguiar & Pascoal
  2007): a neighbour's gamma is assumed to advance at the fleet's reference rate; its rate is kept as heard.
A message takes effect no earlier than its arrival; a message older than the one held is ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Protocol, runtime_checkable

import msgspec
from annotated_types import Gt


class NeighbourEstimate(msgspec.Struct, frozen=True):
    """What a vehicle holds of a neighbour (or says of itself). A msgspec struct, immutable: a changed copy is
    msgspec.structs.replace(estimate, ...), not dataclasses.replace."""

    gamma: float
    gamma_dot: float
    stamp: float  # sender's simulation time of the data, s


@runtime_checkable
class Predictor(Protocol):
    """How a receiver predicts a neighbour between its messages.

    predict(estimate, t, v_r): the neighbour's (gamma_hat, gamma_dot_hat) at time t [s] from the last estimate
    received (gamma in the path's unit of gamma, gamma_dot in unit of gamma per s, stamp in s; t >= stamp), v_r the
    fleet's reference rate [unit of gamma per s]. Must be pure and return finite floats."""

    def predict(self, estimate: NeighbourEstimate, t: float, v_r: float) -> tuple[float, float]: ...


@dataclass(frozen=True, slots=True)
class FirstOrder:
    """gamma + gamma_dot min(age, horizon): a constant-rate extrapolation, over at most `horizon` s (None: for ever)."""

    horizon: Annotated[float, Gt(0)] | None = None

    def predict(self, estimate: NeighbourEstimate, t: float, v_r: float) -> tuple[float, float]:
        age = t - estimate.stamp
        if self.horizon is not None and age > self.horizon:
            age = self.horizon
        return estimate.gamma + estimate.gamma_dot * age, estimate.gamma_dot


@dataclass(frozen=True, slots=True)
class Hold:
    """gamma as last heard (zero-order hold)."""

    def predict(self, estimate: NeighbourEstimate, t: float, v_r: float) -> tuple[float, float]:
        return estimate.gamma, estimate.gamma_dot


@dataclass(frozen=True, slots=True)
class Reference:
    """gamma + v_r age (its rate as heard): gamma assumed to advance at the reference rate (Rego et al. 2019)."""

    def predict(self, estimate: NeighbourEstimate, t: float, v_r: float) -> tuple[float, float]:
        return estimate.gamma + v_r * (t - estimate.stamp), estimate.gamma_dot


def fresh(estimate: NeighbourEstimate, t: float, max_age: float | None) -> bool:
    """Whether an estimate still counts at t: no older than max_age s (None: always). An expired neighbour leaves
    the law until it is heard again (a switching topology: Ghabcheloo et al., SIAM J. Control Optim. 48(1), 2009)."""
    return max_age is None or t - estimate.stamp <= max_age


def newer(held: NeighbourEstimate | None, incoming: NeighbourEstimate) -> bool:
    """Whether an incoming estimate should replace the held one (late, reordered packets must not go back)."""
    return held is None or incoming.stamp > held.stamp


def finite_pair(value: tuple[float, float]) -> bool:
    """Whether a (gamma, gamma_dot) an extension returned is two finite floats."""
    return math.isfinite(value[0]) and math.isfinite(value[1])

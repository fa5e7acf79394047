"""Stability of the fleet's coordination loop predicted before a run: the linearised sampled-data loop of law (5)
(Aguiar & Pascoal, "Coordinated path-following control for nonlinear systems with logic-based communication",
CDC 2007) with the receivers' predictors, its decay rate, and the largest transmit period, delay and i.i.d. loss it
tolerates (docs/stability.md). model: the loop and the sampling; monodromy: the maps over one period; margins: rate
and bisections; scenario: from a Scenario, and the paragraph cpf stability prints.

Assumed: perfect path following; linearisation about the synchronised motion (exact for the affine law, saturations
left out); periodic synchronous sampling or TDMA offsets; one constant delay; independent losses (mean-square
stability). Optimistic for bursty loss and for event-triggered transmission without a heartbeat; conservative in
asking mean-square rather than almost-sure convergence. Ghabcheloo, Aguiar, Pascoal, Silvestre, Kaminer & Hespanha,
SIAM J. Control Optim. 48(1), 2009, prove boundedness under bounded delays and losses; this gives the numbers for
one fleet. The reference-speed predictor is that of logic-based communication (Rego, Hung, Jones, Pascoal & Aguiar,
IET Control Theory Appl., 2019)."""

from supervisor.config.stability.margins import (
    Setting,
    converges,
    largest_delay,
    largest_loss,
    largest_period,
    rate,
)
from supervisor.config.stability.model import Loop, Sampling
from supervisor.config.stability.scenario import Verdict, analyse, describe, setting_of

__all__ = [
    "Loop",
    "Sampling",
    "Setting",
    "Verdict",
    "analyse",
    "converges",
    "describe",
    "largest_delay",
    "largest_loss",
    "largest_period",
    "rate",
    "setting_of",
]

"""Stability of the fleet's coordination loop predicted before a run: the linearised sampled-data loop of law (5)
with the receivers' predictors, its decay rate, and the largest transmit period, delay and loss it tolerates
(docs/stability.md). model: the loop and the sampling; monodromy: the maps over one period; margins: rate and
bisections; scenario: from a Scenario, and the paragraph cpf stability prints."""

from supervisor.analysis.stability.margins import (
    Setting,
    converges,
    largest_delay,
    largest_loss,
    largest_period,
    rate,
)
from supervisor.analysis.stability.model import Loop, Sampling
from supervisor.analysis.stability.scenario import Verdict, analyse, describe, setting_of

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

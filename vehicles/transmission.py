"""When a vehicle transmits its coordination state, and what it sends.

The policy is a pure decision on (time, last transmission). Periodic: every `period` seconds (every sync step when
period is None). The event-triggered policy of logic-based communication will sit beside it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Transmission:
    """A coordination message as it leaves a vehicle: its data and, for the channel emulator only, its kinematics."""

    sender: int
    seq: int
    t: float  # transmission time, which is also the time of the data, s
    gamma: float
    gamma_dot: float
    position: tuple[float, float, float]  # inertial, m
    velocity: tuple[float, float, float]  # inertial, m/s


@dataclass(frozen=True, slots=True)
class PeriodicPolicy:
    period: float | None = None  # s; None: every sync step

    def due(self, t: float, last: float | None, dt: float) -> bool:
        """Whether to transmit at t; half a step of slack keeps the schedule on the step grid."""
        if last is None or self.period is None:
            return True
        return t - last >= self.period - dt / 2

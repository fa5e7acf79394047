"""Plausibility of a vehicle's state report against what its own model and the step allow: a speed no faster than
its bound, a position and a gamma that move no further from the vehicle's previous step than their rates allow, a
gamma_dot within its bound. The numbers come from the scenario, in one place (supervisor.config.plausibility, documented
in docs/plausibility.md); this is their check, the same in the supervisor's intake and the broker. A state beyond them
is a ValueError (comms.records.bounded.dropped) with the cause IMPLAUSIBLE: dropped before it reaches another vehicle
or the log, and the vehicle's fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from comms.records.bounded import dropped
from comms.records.records import Transmission
from comms.records.state import StateReport
from comms.records.stream import IMPLAUSIBLE

SLACK = 1.0  # m (and units of gamma) a step's bounds allow on top of rate x time: rounding, a restart's resumption
# A path parameter beyond its bounds is what a coordination loop that really diverges sends too (the in-process
# engine, which checks no bounds, runs on and reports it as diverged): the reason says both.
DIVERGED_OR_LIES = "; its coordination loop diverged or it lies: `cpf stability` says whether the loop converges"


@dataclass(frozen=True, slots=True)
class Lie:
    """A gamma the scenario's own faults make a vehicle transmit other than its state's, over its sync steps first ..
    end - 1 (end None: to the end of the run): at most offset, plus drift (unit of gamma per s) times the time since
    its first step: a gamma_offset fault's offset; a stuck gamma sensor's reading, which its gamma leaves behind."""

    first: int
    end: int | None
    offset: float = 0.0
    drift: float = 0.0

    def at(self, k: int, dt: float) -> float:
        """How far it lets the transmission of step k be from the state's gamma (0 outside its steps)."""
        if k < self.first or (self.end is not None and k >= self.end):
            return 0.0
        return self.offset + self.drift * (k - self.first) * dt


@dataclass(frozen=True, slots=True)
class Plausible:
    """One vehicle's bounds: speed through the water (m/s), speed over ground with the current (m/s), |gamma_dot|;
    lies: when and how far the scenario's own faults make the gamma it transmits differ from its state's."""

    speed: float
    ground_speed: float
    gamma_dot: float
    lies: tuple[Lie, ...] = ()

    def lie(self, k: int, dt: float) -> float:
        """How far the scenario's faults make the gamma it transmits at step k differ from its state's (unit of
        gamma): the lies in force then, added up (overlapping ones add)."""
        return sum(lie.at(k, dt) for lie in self.lies)

    def check(self, report: StateReport, previous: StateReport | None, dt: float) -> None:
        """ValueError (dropped: implausible) for a state beyond the bounds, alone or against the vehicle's previous
        step (previous: None for its first)."""
        speed = math.hypot(*report.velocity)
        if speed > self.speed:
            _refuse(report, f"speed {speed:.3g} m/s above its {self.speed:.3g} m/s")
        if abs(report.gamma_dot) > self.gamma_dot:
            _refuse(report, f"gamma_dot {report.gamma_dot:.3g} beyond its {self.gamma_dot:.3g}{DIVERGED_OR_LIES}")
        if previous is None or report.k <= previous.k:
            return
        elapsed = (report.k - previous.k) * dt
        moved = math.dist(report.position, previous.position)
        if moved > self.ground_speed * elapsed + SLACK:
            _refuse(report, f"moved {moved:.3g} m in {elapsed:.3g} s (at most {self.ground_speed:.3g} m/s)")
        if abs(report.gamma - previous.gamma) > self.gamma_dot * elapsed + SLACK:
            _refuse(
                report, f"gamma went {previous.gamma:.6g} -> {report.gamma:.3g} in {elapsed:.3g} s{DIVERGED_OR_LIES}"
            )

    def check_tx(self, tx: Transmission, report: StateReport, dt: float) -> None:
        """ValueError (dropped: implausible) for a transmission beyond the bounds, or further from the state of its
        step than a step and the scenario's own lies at that step allow (its data goes to the neighbours: a plausible
        state must not carry an absurd one). The step is the state's, which the transmission's t (its send time) is
        held to: a skewed clock's stamp does not move it."""
        told = abs(tx.gamma - report.gamma) - (self.gamma_dot * dt + SLACK)  # beyond a step's: > 0
        if (
            abs(tx.gamma_dot) > self.gamma_dot
            or (told > 0.0 and told > self.lie(report.k, dt))  # the lies in force summed only for such a one
            or math.hypot(*tx.velocity) > self.ground_speed
            or math.dist(tx.position, report.position) > self.ground_speed * dt + SLACK
        ):
            _refuse(report, f"its transmission (gamma {tx.gamma:.3g}, gamma_dot {tx.gamma_dot:.3g}) is not its state's")


def _refuse(report: StateReport, why: str) -> None:
    raise dropped(IMPLAUSIBLE, f"vehicle {report.vehicle}'s state of step {report.k}: {why}")

"""Theory held against the simulator: run a scenario in process and say whether its coordination converged.

"Converged" is what a person would read off the coordination error c(t) = max_ij |gamma_i - gamma_j|
(supervisor.analysis.summary.coordination_error): over the last `window` s its peak is below `tolerance`, or it is
shrinking (the last window's peak under half the one before). "Diverged" is its peak still growing.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from supervisor.analysis.summary import coordination_error
from supervisor.config.scenario import parse_scenario
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress


@dataclass(frozen=True)
class Outcome:
    """Peaks of the coordination error over the window before the last and over the last one."""

    before: float
    last: float
    final: float  # at the end of the run
    path_error: float = float("nan")  # m, the largest |p_i - p_d_i| of any vehicle after the report's transient

    def converged(self, tolerance: float) -> bool:
        return self.last < tolerance or self.last < 0.5 * self.before

    def diverged(self) -> bool:
        return self.last > self.before


def simulate(scenario: Scenario, window: float = 50.0) -> Outcome:
    """Run the scenario in process (nothing recorded) and read its coordination error."""
    quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
    result = run_inprocess(scenario, "stability-check", "", None, scenario.scenario.seed, quiet)
    error = coordination_error(result.series.gamma)
    t = result.series.t
    end = t[-1]
    last = error[t > end - window]
    before = error[(t > end - 2 * window) & (t <= end - window)]
    after = result.series.path_error[t >= scenario.report.transient]
    return Outcome(float(np.nanmax(before)), float(np.nanmax(last)), float(error[-1]), float(np.nanmax(after)))


def scenario_with(path: Path, overrides: list[str]) -> Scenario:
    return parse_scenario(path.read_text(), str(path), overrides)

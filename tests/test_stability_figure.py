"""The stability figure's script (scripts/stability_figure.py, docs/stability.md): its runs are the loop whose
boundary it draws. Its runs themselves are not made here (15 runs of 300 s): simulate is stubbed."""

from __future__ import annotations

from pathlib import Path

import pytest

from supervisor.config.scenario_schema import Scenario
from supervisor.config.stability import Setting, setting_of
from supervisor.tools.stability_check import Outcome
from tests.procs import script


def test_the_figures_runs_are_the_loop_of_the_boundary_it_draws(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """The runs kept the scenario's gain scheduling and correction saturation: every 7.6-11 s first_order ran with k
    0.07-0.1 under the k = 0.2 boundary (7.31 s) drawn over them, and the text read those runs against it."""
    figure = script("stability_figure")
    runs: list[Scenario] = []
    drawn: list[Setting] = []

    def simulate(scenario: Scenario) -> Outcome:
        runs.append(scenario)
        return Outcome(1.0, 1.0, 1.0)

    def largest_period(setting: Setting) -> float | None:
        drawn.append(setting)
        return None

    monkeypatch.setattr(figure, "simulate", simulate)
    monkeypatch.setattr(figure, "largest_period", largest_period)
    figure.main(tmp_path / "period.png")
    assert len(runs) == sum(len(periods) for periods in figure.PERIODS.values()) and len(drawn) == 2
    for scenario in runs:
        boundary = next(s for s in drawn if s.loop.predictor == scenario.coordination.predictor)
        assert setting_of(scenario).loop.k == boundary.loop.k == scenario.coordination.k == 0.2
        assert (scenario.coordination.schedule, scenario.saturation.correction) == ("none", "none")

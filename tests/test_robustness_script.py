"""The robustness study script's own logic (scripts/robustness_study.py): each effect switched on alone, the plan of
runs, the measures over the study's windows and the table's median [min-max]. Its scenario and results are
tests/test_robustness_study.py's."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from supervisor.config.scenario import validate_data
from tests.procs import script

study = script("robustness_study")


def _on(data: dict) -> set[str]:
    """Which effects a scenario's data has on."""
    on = set()
    if any(data.get("environment", {}).get("current", [0.0])):
        on.add("current")
    if "navigation" in data:
        on.add("navigation")
    if data["vehicle"].get("uncertainty", 0.0) > 0:
        on.add("mismatch")
    if "range" in data["comms"]:
        on.add("loss")
    return on


@pytest.mark.parametrize("effect", study.EFFECTS)
def test_each_variant_has_only_its_effect_on_and_is_a_valid_scenario(effect: str) -> None:
    base = tomllib.loads(study.STUDY.read_text())
    before = repr(base)
    data = study.variant(base, effect)
    everything = {"current", "navigation", "mismatch", "loss"}
    assert _on(data) == {"none": set(), "all": everything}.get(effect, {effect})
    validate_data(data, str(study.STUDY))
    assert repr(base) == before  # the base is not changed for the next variant


def test_the_plan_runs_every_effect_and_sweep_value_over_every_seed() -> None:
    runs = study.plan(3)
    assert len(runs) == 3 * (len(study.EFFECTS) + len(study.FIX_PERIODS) + len(study.CURRENTS))
    assert {(g, v) for g, _, v, _ in runs if g == "fix_period"} == {("fix_period", v) for v in study.FIX_PERIODS}
    assert all(sorted(s for g, e, v, s in runs if (g, e, v) == key) == [0, 1, 2] for key in {r[:3] for r in runs})
    data = study.scenario_data(tomllib.loads(study.STUDY.read_text()), ("current", "all", 0.3, 2))
    assert data["environment"]["current"] == [0.3, 0.0, 0.0] and data["scenario"]["seed"] == 2


def test_the_measures_take_their_own_windows() -> None:
    """Path error after the transient and over the last 50 s; coordination error over the settled windows
    [100, 150) and [300, end] (a spike at 200 s, inside the fault, is not counted) and over the last 50 s."""
    t = np.arange(4000) * 0.1
    path = np.where(t < 50.0, 99.0, 1.0)
    path[t >= 340.0] = 0.5  # the last 50 s (from 349.9 s) see only this
    path[2000] = 7.0  # t = 200 s, after the transient
    gamma = np.zeros((len(t), 2))
    gamma[t >= 120.0, 1] = 0.3  # settled window, not the last 50 s
    gamma[t >= 140.0, 1] = 0.0
    gamma[2000, 1] = 5.0  # the fault's spike
    gamma[3990, 1] = 0.2  # in the last 50 s and the second settled window
    got = study._errors(t, path, gamma, 50.0)
    assert got == {"path_max": 7.0, "path_steady": 0.5, "coord_settled": 0.3, "coord_steady": 0.2}


def test_the_table_gives_the_median_and_range_per_value_of_a_group() -> None:
    measures = [c for c, _ in study.COLUMNS]
    rows = [
        {"group": "current", "value": v, **{c: x for c in measures}}
        for v, x in [(0.1, 1.0), (0.1, 6.0), (0.1, 2.0), (0.2, 5.0)]
    ] + [{"group": "effects", "value": 0.0, **{c: 9.0 for c in measures}}]
    lines = study.table(rows, "current", "value").splitlines()
    assert len(lines) == 4  # head, rule, one line per value of the group
    assert lines[2] == "| 0.1 | " + " | ".join(["2 [1-6]"] * len(measures)) + " |"
    assert lines[3] == "| 0.2 | " + " | ".join(["5 [5-5]"] * len(measures)) + " |"

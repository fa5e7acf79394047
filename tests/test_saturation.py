"""Saturation ([saturation]): a top speed along the path with no wind-up, and the bounded (tanh) correction.

A loop that diverges unsaturated stays bounded saturated: six AUVs on lawnmower strips, TDMA with a 24 s frame over
a slow, bursty modem, default gains (tests/data/fig_lawnmower6.toml).

    1 - 2 - 3 - 4 - 5 - 6   (line graph)
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from comms.records.records import Disturbances
from supervisor.analysis.rundata import load_run
from supervisor.analysis.saturation_summary import at_limit, format_limits
from supervisor.analysis.summary import Series
from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import parse_scenario
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf
from tests.run_digest import digest
from vehicles.agent import step
from vehicles.estimates import NeighbourEstimate
from vehicles.saturation import bounded_correction, hold, rate_bound

PAPER = (CONFIGS / "paper.toml").read_text()
SURVEY = Path(__file__).resolve().parent / "data" / "fig_lawnmower6.toml"


def _saturated(text: str, table: str) -> str:
    return text.replace("[path_following]", f"[saturation]\n{table}\n\n[path_following]", 1)


def test_the_bounded_correction_is_law_5_when_small_and_never_past_its_bound():
    assert bounded_correction(1e-4, 0.5) == pytest.approx(1e-4, rel=1e-7)
    assert bounded_correction(-1e6, 0.5) == -0.5 and abs(bounded_correction(3.0, 0.5)) < 0.5


def test_the_integrator_is_held_only_in_the_direction_past_the_bound():
    assert hold(2.0, 1.0, -1.0, 1.0) == 0.0 and hold(-2.0, 1.0, -1.0, 1.0) == -2.0
    assert hold(-2.0, -1.0, -1.0, 1.0) == 0.0 and hold(2.0, 0.5, -1.0, 1.0) == 2.0


def test_a_vehicle_pulled_hard_by_its_neighbours_stays_at_its_top_speed_along_the_path():
    sc = parse_scenario(_saturated(PAPER, "top_speed = 0.5"), "sat.toml")
    cfg = vehicle_config(sc, 1)
    state = initial_state(sc, cfg)
    for j in (2, 3):  # neighbours far ahead and fast: law (5) alone would run gamma_dot away
        state = state.__class__(state.t, state.x, state.gamma, state.gamma_dot, {
            **state.estimates, j: NeighbourEstimate(state.gamma + 500.0, 50.0, 0.0)})  # fmt: skip
    rates = []
    for _ in range(300):
        state, _ = step(cfg, state, 0.1, [2, 3])
        rates.append(abs(state.gamma_dot) / rate_bound(cfg.model, cfg.path, state.gamma, 0.5))
    assert max(rates) == pytest.approx(1.0, abs=1e-12)  # reached and held, never past
    assert rates[-1] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("ahead", [True, False])
def test_a_speed_cap_under_the_top_speed_holds_gamma_dot_at_the_cap_and_the_bound_still_holds_it_below(ahead):
    # The speed_cap fault and the top speed are one interval [-bound, min(cap, bound)] (vehicles.agent._rate_limits).
    # The correction unbounded: the neighbours' pull must reach the top speed backwards (bounded by default, it does
    # not: the thrust bound keeps the correction below what would take gamma_dot there).
    sc = parse_scenario(_saturated(PAPER, "top_speed = 0.5\ncorrection = 'none'"), "sat.toml")
    cfg = vehicle_config(sc, 1)
    state = initial_state(sc, cfg)
    cap = 0.5 * rate_bound(cfg.model, cfg.path, state.gamma, 0.5)
    pull = (
        NeighbourEstimate(state.gamma + 500.0, 50.0, 0.0)
        if ahead
        else NeighbourEstimate(state.gamma - 500.0, -50.0, 0.0)
    )
    state = state.__class__(state.t, state.x, state.gamma, state.gamma_dot, {2: pull, 3: pull})
    rates = []
    for _ in range(300):
        state, _ = step(cfg, state, 0.1, [2, 3], Disturbances(gamma_dot_cap=cap))
        rates.append((state.gamma_dot, -rate_bound(cfg.model, cfg.path, state.gamma, 0.5)))
    if ahead:
        assert max(g for g, _ in rates) == cap and rates[-1][0] == cap  # reached and held, never past
    else:
        assert min(g - low for g, low in rates) == pytest.approx(0.0, abs=1e-12)
        assert rates[-1][0] == pytest.approx(rates[-1][1], abs=1e-12)  # backwards at the top speed, held there


def test_the_summary_lists_the_spans_at_the_limit():
    sc = parse_scenario(_saturated(PAPER, "top_speed = 0.5"), "sat.toml")
    cfg = vehicle_config(sc, 1)
    t = np.arange(10, dtype=np.float64) * np.float64(0.1)
    gamma = np.full((10, 3), np.nan)
    gamma[:, 0] = 1.0
    bound = rate_bound(cfg.model, cfg.path, 1.0, 0.5)
    rate = np.full((10, 3), np.nan)
    rate[:, 0] = [0.0, bound, bound, 0.5 * bound, 0.0, 0.0, -bound, -bound, -bound, 0.0]
    series = Series((1, 2, 3), t, gamma, rate, np.zeros((10, 3)))
    limits = at_limit(sc, series)
    assert limits is not None and np.allclose(limits[0].spans, [(0.1, 0.3), (0.6, 0.9)])
    assert limits[0].total == pytest.approx(0.5) and limits[1].spans == ()
    text = format_limits(limits, 1.0)
    assert text is not None and "vehicle 1: at its speed limit (0.5 m/s) for 0.5 s of 1 s, 2 span(s)" in text
    assert at_limit(parse_scenario(PAPER, "paper.toml"), series) is None  # off: nothing to say


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ("top_speed = -1.0", "saturation.top_speed: must be greater than 0"),
        ('top_speed = "fast"', "saturation.top_speed: "),
        ("correction = 0.0", "saturation.correction: must be greater than 0 or 'preset' or 'none', got 0.0"),
        ("speed = 1.0", "saturation.speed: unknown key"),
    ],
)
def test_bad_saturation_keys_are_one_line_errors(table, message):
    with pytest.raises(ScenarioError) as info:
        parse_scenario(_saturated(PAPER, table), "sat.toml")
    assert info.value.errors[0].startswith(f"sat.toml: {message}") and "\n" not in info.value.errors[0]


def _survey(tmp_path: Path, name: str, extra: list[str]) -> dict[int, tuple[float, float]]:
    """(max |gamma_dot|, max path error after 50 s) per vehicle of the survey over 600 s, in-process."""
    out = tmp_path / f"{name}.mcap"
    done = cpf("run", str(SURVEY), "--engine", "inprocess", "--quiet", "--out", str(out),
               "--set", "scenario.duration=600", *extra, cwd=tmp_path)  # fmt: skip
    assert done.returncode == 0, done.stderr
    run = load_run(out)
    after = {v: s.t >= 50.0 for v, s in run.vehicles.items()}
    return {v: (float(np.max(np.abs(s.gamma_dot))), float(np.max(s.error_norm[after[v]])))
            for v, s in run.vehicles.items()}  # fmt: skip


# Law (5) as the paper has it: the defaults since issue 23 (reference predictor, fitted k, bounded correction) keep
# this survey coordinated on their own (tests/test_gain_schedule.py).
FORMER = ["--set", "coordination.predictor=first_order", "--set", "coordination.schedule=none",
          "--set", "saturation.correction=none"]  # fmt: skip


def test_the_survey_that_diverges_unsaturated_stays_bounded_with_a_top_speed(tmp_path):
    free = _survey(tmp_path, "free", FORMER)
    assert max(rate for rate, _ in free.values()) > 20.0  # gamma_dot runs away (1 is the reference)
    assert max(error for _, error in free.values()) > 100.0  # and the vehicles leave their paths
    held = _survey(
        tmp_path, "held", [*FORMER, "--set", "saturation.top_speed=1.5", "--set", "saturation.correction=0.1"]
    )
    assert max(rate for rate, _ in held.values()) <= 1.5 * (1 + 1e-12)  # 1 m of path per unit of gamma
    assert max(error for _, error in held.values()) < 2.0  # back in the 1.2 m tube, give or take the turns


def test_both_engines_agree_with_a_mixed_fleet_and_saturation_on(tmp_path):
    text = shortened(_saturated(PAPER, "top_speed = 0.3\ncorrection = 0.05"), 20.0)
    text = text.replace("id = 2\nposition = [5.0, 0.0, 0.0]\n",
                        'id = 2\nposition = [5.0, 0.0, 0.0]\npreset = "remus100"\n'
                        "overrides = { max_surge_force = 10.0 }\n", 1)  # fmt: skip
    scenario = tmp_path / "mixed.toml"
    scenario.write_text(text)
    digests, outputs = [], []
    for engine in ("inprocess", "zenoh"):
        done = cpf("run", str(scenario), "--engine", engine, "--out", f"{engine}.mcap", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        digests.append(digest(tmp_path / f"{engine}.mcap"))
        outputs.append(done.stdout)
    assert digests[0] == digests[1]
    assert all(re.search(r"vehicle 1: at its speed limit \(0\.3 m/s\) for [1-9]", out) for out in outputs)
    assert int(digests[0]["state"].split(":")[0]) == 3 * 200

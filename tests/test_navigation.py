"""Navigation ([navigation], vehicles.navigation): the filter against the truth, the state message's estimate, the
section's validation, and both engines (and a restart) giving the same records with navigation on.

    2 ---- 1 ---- 3     (the paper's graph, 30 s, navigation fixes every 2 s with dropouts)
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from comms.records.state import StateReport
from supervisor.config.fleet import initial_state, radio, restarted_node, vehicle_config
from supervisor.config.scenario import load_scenario
from supervisor.errors import ScenarioError
from tests.conftest import shortened
from tests.procs import cpf
from tests.test_cosim_e2e import states
from vehicles.agent import UNDISTURBED, step
from vehicles.navigation import FIX, FIX_LOST, HeldError, NavParams, NavState, fix_due, initial, navigate
from vehicles.runtime import NodeState
from vehicles.step import step_records

NAV = "\n[navigation]\nfix_period = 2.0\nfix_noise = 1.0\nfix_dropout = 0.3\n"


def _params(seed: int = 3, **changes: float) -> NavParams:
    numbers = dict(
        dvl_noise=0.01, dvl_bias=0.01, heading_noise=math.radians(1.0), depth_noise=0.05, fix_period=10.0,
        fix_noise=1.0, fix_dropout=0.2, initial_error=1.0,
    )  # fmt: skip
    numbers.update(changes)
    return NavParams(seed, 1, **numbers)  # type: ignore[arg-type]


def _truth(t: float) -> list[float]:
    """A vehicle circling at 1 m/s on a 30 m circle, climbing slowly: lifted [p, R, v (body), omega]."""
    speed, radius = 1.0, 30.0
    psi = speed * t / radius
    c, s = math.cos(psi), math.sin(psi)
    p = [radius * s, radius * (1 - c), -10.0 + 0.01 * t]
    return [*p, c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0, speed, 0.0, 0.01, 0.0, 0.0, speed / radius]


def _run_filter(params: NavParams, steps: int, dt: float) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(position errors, position covariances, fix outcomes) of the filter over a known truth."""
    nav = initial(params, _truth(0.0))
    errors, covs, fixes = [], [], []
    for k in range(steps):
        s = _truth(k * dt)
        out = navigate(params, nav, s, k, dt)
        errors.append(out.posterior.x[0:3] - np.array(s[0:3]))
        covs.append(out.posterior.cov[0:3, 0:3])
        fixes.append(out.fix)
        nav = out.prior
    return np.array(errors), np.array(covs), fixes


def test_the_filter_error_stays_bounded_and_consistent_with_its_covariance():
    dt, steps = 0.1, 6000  # 600 s, 60 fixes
    errors, covs, fixes = _run_filter(_params(), steps, dt)
    nees = np.einsum("ki,kij,kj->k", errors, np.linalg.inv(covs), errors)  # chi-square with 3 dof if consistent
    after = nees[200:]  # past the first fixes
    assert 2.0 <= after.mean() <= 4.5  # E[NEES] = 3; the samples are correlated in time, hence a wide band
    sigma = np.sqrt(np.einsum("kii->ki", covs))
    assert np.mean(np.abs(errors) <= 3 * sigma) >= 0.97
    horizontal = np.linalg.norm(errors[:, :2], axis=1)
    assert horizontal[200:].max() < 4.0  # 1 m fixes every 10 s keep it to a few metres
    assert fixes.count(FIX) + fixes.count(FIX_LOST) == 59 and fixes.count(FIX_LOST) > 0


def test_dead_reckoning_alone_drifts_and_the_filter_knows_it():
    dt, steps = 0.1, 3000
    errors, covs, _ = _run_filter(_params(fix_period=1e6, dvl_bias=0.05), steps, dt)
    sigma = np.sqrt(covs[:, 0, 0] + covs[:, 1, 1])
    assert sigma[-1] > 2 * sigma[100]  # no fix: the uncertainty grows
    assert np.linalg.norm(errors[-1, :2]) < 3 * sigma[-1] + 1.0


def test_the_noise_is_the_same_whatever_came_before():
    """Stateless draws: step k's measurements depend on (seed, vehicle, k) only."""
    params, s = _params(), _truth(12.3)
    nav = initial(params, s)
    a = navigate(params, nav, s, 123, 0.1)
    navigate(params, nav, s, 7, 0.1)  # another step in between draws nothing from a shared stream
    b = navigate(params, nav, s, 123, 0.1)
    assert a.posterior.flat() == b.posterior.flat() and a.held == b.held
    assert navigate(_params(seed=4), nav, s, 123, 0.1).held != a.held


def test_fixes_come_at_the_first_step_at_or_after_each_period():
    assert [k for k in range(1, 100) if fix_due(k, 0.1, 3.0)] == [30, 60, 90]
    assert [k for k in range(1, 20) if fix_due(k, 0.3, 1.0)] == [4, 7, 10, 14, 17]
    assert not fix_due(0, 0.1, 3.0)


def test_the_filter_state_survives_its_wire_form_exactly():
    params = _params()
    out = navigate(params, initial(params, _truth(0.0)), _truth(0.0), 0, 0.1)
    for state in (out.posterior, out.prior):
        back = NavState.from_flat(state.flat())
        assert back.x.tolist() == state.x.tolist() and back.cov.tolist() == state.cov.tolist()
    with pytest.raises(ValueError, match="27 numbers, got 3"):
        NavState.from_flat([1.0, 2.0, 3.0])


def _scenario(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "nav.toml"
    path.write_text(text)
    return path


def test_without_navigation_the_controller_sees_the_truth_and_the_message_has_no_estimate(tmp_path, paper_text):
    sc = load_scenario(_scenario(tmp_path, paper_text))
    cfg = vehicle_config(sc, 1)
    assert cfg.navigation is None
    node = NodeState(initial_state(sc, cfg))
    _, records = step_records(cfg, radio(sc, 1), node, 0, 0.0, 0.1, [], [], UNDISTURBED)
    assert "nav_estimate" not in records.state and records.report.estimated_position is None
    # A zero held error is the truth to the bit: the controller's view and the plant's drift are the true ones.
    zero = HeldError((0.0, 0.0, 0.0), 0.0, (0.0, 0.0, 0.0))
    truth, _ = step(cfg, node.vehicle, 0.1, [])
    held, _ = step(cfg, node.vehicle, 0.1, [], held=zero)
    assert held.x.tolist() == truth.x.tolist()


def test_with_navigation_the_controller_sees_the_estimate_and_the_error_is_the_true_one(tmp_path, paper_text):
    sc = load_scenario(_scenario(tmp_path, paper_text + NAV))
    cfg = vehicle_config(sc, 1, seed=5)
    plain_cfg = vehicle_config(sc.model_copy(update={"navigation": None}), 1)
    node = NodeState(initial_state(sc, cfg))
    after, records = step_records(cfg, radio(sc, 1), node, 0, 0.0, 0.1, [], [], UNDISTURBED)
    after_plain, plain_records = step_records(plain_cfg, radio(sc, 1), node, 0, 0.0, 0.1, [], [], UNDISTURBED)
    report, plain = records.report, plain_records.report
    assert report.estimated_position is not None and report.estimated_position != report.position
    assert report.tau != plain.tau  # the controller acted on its estimate
    np.testing.assert_allclose(report.error, plain.error, atol=1e-12)  # the recorded error is the true p - p_d
    assert after.vehicle.x.tolist() != after_plain.vehicle.x.tolist()  # and the vehicle moved on what it saw


def test_a_restarted_node_starts_its_filter_again_where_the_vehicle_coasted_to(tmp_path, paper_text):
    """The filter's last estimate is of a place the vehicle has left while its computer was down (vehicles.coast):
    the restarted filter starts again as at the run's start, around where the vehicle now is."""
    sc = load_scenario(_scenario(tmp_path, paper_text + NAV))
    cfg = vehicle_config(sc, 2)
    node = NodeState(initial_state(sc, cfg))
    for k in range(25):
        node, records = step_records(cfg, radio(sc, 2), node, k, k * 0.1, 0.1, [], [1], UNDISTURBED)
    restarted = restarted_node(cfg, records.state, node.seq, 45, 0.1, sc.faults)
    assert records.report.nav_estimate is not None and restarted.nav is None
    assert restarted.vehicle.t == pytest.approx(4.5) and restarted.vehicle.x.tolist() != node.vehicle.x.tolist()
    assert StateReport.from_message(records.state, 2) == records.report  # the message reads as the report


@pytest.mark.parametrize(
    ("line", "field", "problem", "value"),
    [
        ("fix_period = -10.0", "navigation.fix_period", "must be greater than 0", "-10.0"),
        ("fix_dropout = 1.5", "navigation.fix_dropout", "must be less than or equal to 1", "1.5"),
        ("dvl_noise = -0.1", "navigation.dvl_noise", "must be greater than or equal to 0", "-0.1"),
        ("fix_noise = 0.0", "navigation.fix_noise", "must be greater than 0", "0.0"),
        ("heading_noise_deg = 90.0", "navigation.heading_noise_deg", "must be less than or equal to 45", "90.0"),
        ('fix_period = "10"', "navigation.fix_period", "must be a valid number", "'10'"),
        ("gps = true", "navigation.gps", "unknown key", None),
    ],
)
def test_every_navigation_key_is_validated_with_a_one_line_error(tmp_path, paper_text, line, field, problem, value):
    bad = _scenario(tmp_path, paper_text + f"\n[navigation]\n{line}\n")
    with pytest.raises(ScenarioError) as info:
        load_scenario(bad)
    got = "" if value is None else f", got {value}"
    assert str(info.value) == f"{bad}: {field}: {problem}{got}"


def _nav_fields(run: dict[tuple[int, int], dict]) -> dict[tuple[int, int], tuple]:
    return {key: (m["nav_estimate"], m["nav_fix"], m["position"], m["gamma"]) for key, m in run.items()}


@pytest.mark.parametrize("kill", [False, True], ids=["plain", "restart"])
def test_both_engines_give_identical_records_with_navigation_on(tmp_path, paper_text, kill):
    scenario = _scenario(tmp_path, shortened(paper_text, 20.0) + NAV)
    extra = ["--seed", "11"]
    if kill:
        extra += ["--set", "scenario.on_vehicle_loss=continue", "--fault", "kind=vehicle_kill,vehicle=3,start=8,end=10"]
    runs = {}
    for engine in ("zenoh", "inprocess"):
        done = cpf("run", str(scenario), *extra, "--engine", engine, "--out", f"{engine}.mcap", "--quiet", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        runs[engine] = states(tmp_path / f"{engine}.mcap")
    zen, inp = runs["zenoh"], runs["inprocess"]
    assert len(zen) == (3 * 200 - (20 if kill else 0)) and zen == inp  # every record, to the bit
    assert {m["nav_fix"] for m in zen.values()} >= {0, 1}
    if kill:  # the restarted vehicle's filter starts afresh where the vehicle coasted to, not from its old estimate
        before, after = zen[(3, 79)], zen[(3, 100)]
        cfg = vehicle_config(load_scenario(scenario), 3, seed=11)
        node = restarted_node(cfg, before, 0, 100, 0.1, ())
        assert cfg.navigation is not None and node.nav is None
        s = cfg.model.lift(node.vehicle.x)
        resumed = navigate(cfg.navigation, initial(cfg.navigation, s), s, 100, 0.1)
        assert list(resumed.posterior.flat()) == after["nav_estimate"]
        assert after["position"] != before["position"]  # it moved while down


def test_the_report_draws_the_navigation_figure_only_for_a_run_with_navigation(tmp_path, paper_text):
    """A run with navigation; the report of one without (no figure, no metrics, has_navigation false) is checked on
    the plain paper run of tests/test_cli_e2e.py, which draws its report anyway."""
    from supervisor.analysis.figures_nav import has_navigation
    from supervisor.analysis.rundata import load_run

    scenario = _scenario(tmp_path, shortened(paper_text, 12.0) + NAV)
    short = ("--set", "report.transient=2.0")  # the metrics are taken after the transient
    done = cpf("run", str(scenario), "--engine", "inprocess", "--out", "nav.mcap", "--quiet", *short, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    report = cpf("report", "nav.mcap", "--out", "nav", cwd=tmp_path)
    assert report.returncode == 0, report.stderr
    assert (tmp_path / "nav" / "navigation_errors.png").exists()
    assert has_navigation(load_run(tmp_path / "nav.mcap"))
    series = load_run(tmp_path / "nav.mcap").vehicles[1]
    assert series.nav_error is not None and series.nav_fix is not None
    assert 0.0 < float(series.nav_error.max()) < 10.0 and set(series.nav_fix.tolist()) >= {0, 1}
    nav = json.loads((tmp_path / "nav" / "metrics.json").read_text())["navigation"]
    assert set(nav) == {"1", "2", "3"}
    assert nav["1"]["fixes_fused"] == int((series.nav_fix == 1).sum()) > 0
    assert 0.0 < nav["1"]["mean_error"] <= nav["1"]["max_error"] <= float(series.nav_error.max())

"""The defaults that keep a fleet coordinated on real acoustic links (issue 23): the reference-speed predictor, law
(5)'s k fitted to the links by the stability analysis (supervisor/config/stability/schedule.py) and the correction
bounded by what each vehicle's thrust allows (vehicles/saturation.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from supervisor.config.derived import tube_radius
from supervisor.config.scenario import parse_scenario
from supervisor.config.stability import Setting, rate
from supervisor.config.stability.scenario import coupling_gain, nominal_setting, setting_of
from supervisor.tools.stability_check import simulate
from tests.conftest import CONFIGS
from vehicles.params import preset
from vehicles.saturation import COORDINATION_SHARE, coordination_acceleration

PAPER = (CONFIGS / "paper.toml").read_text()


def _paper(*overrides: str):
    return parse_scenario(PAPER, "paper.toml", list(overrides))


def _with_k(setting: Setting, k: float) -> Setting:
    return replace(setting, loop=replace(setting.loop, k=k))


def test_with_a_message_every_step_the_scenarios_k_is_kept():
    assert coupling_gain(_paper()) == 0.2


@pytest.mark.parametrize("period", [20.0, 30.0])
def test_on_slow_links_the_fitted_k_decays_several_times_faster_than_the_given_one(period):
    """The paper's loop with a message every 20 or 30 s: 0.2 over-corrects from old news (predicted decay 0.009 and
    0.002 1/s); the fitted gain decays at >= 0.025 1/s, and no gain of a finer scan does more than 10 % better."""
    scenario = _paper(f"comms.transmit.period={period}")
    nominal = nominal_setting(scenario)
    fitted = coupling_gain(scenario)
    assert fitted < 0.2 and setting_of(scenario).loop.k == fitted
    assert rate(_with_k(nominal, fitted)) > 3 * rate(nominal) and rate(_with_k(nominal, fitted)) > 0.025
    finer = max(rate(_with_k(nominal, k)) for k in np.geomspace(0.2 / 16, 0.2, 60))
    assert finer < 1.1 * rate(_with_k(nominal, fitted))


@pytest.mark.parametrize(("period", "first_order"), [(7.6, 0.1), (9.0, 0.0841)])
def test_the_fitted_k_docs_stability_quotes(period, first_order):
    """docs/stability.md: with the defaults k is fitted to first_order's loop, and reference keeps 0.2, at 7.6 and
    9 s (a new user read the doc's numbers as the default predictor's)."""
    fitted = coupling_gain(_paper(f"comms.transmit.period={period}", "coordination.predictor=first_order"))
    assert fitted == pytest.approx(first_order, abs=5e-4)
    assert coupling_gain(_paper(f"comms.transmit.period={period}")) == 0.2


@pytest.mark.parametrize(
    "override", ["coordination.schedule=none", "coordination.law=saturated", "coordination.law=literal"]
)
def test_k_is_as_given_unless_law_5_runs_with_the_schedule(override):
    fitted = coupling_gain(_paper("comms.transmit.period=30", override))
    assert (fitted == 0.2) == (override != "coordination.law=literal")


def test_an_event_triggered_policy_is_fitted_at_the_fastest_it_may_send_not_at_its_heartbeat():
    event = ["comms.transmit.policy=event", "comms.transmit.heartbeat=60", "comms.transmit.min_interval=1"]
    assert coupling_gain(_paper(*event)) == coupling_gain(_paper("comms.transmit.period=1")) == 0.2
    assert nominal_setting(_paper(*event)).period == 60.0  # the verdict stays the conservative one


def test_the_coordinations_share_of_a_remus_is_half_its_thrust_over_its_surge_mass():
    remus = preset("remus100")
    assert coordination_acceleration(remus) == pytest.approx(COORDINATION_SHARE * 14.1088 / 31.87, rel=1e-4)


# --- the simulated fleet: the paper scenario (its speed_cap fault included) on slow links --------------------------


def test_the_paper_scenario_every_10_s_coordinates_and_stays_in_its_tube_with_the_defaults():
    """Issue 23's acceptance, the case that holds: coordination error < 0.05 over the last 50 s, path error (all
    vehicles, every step after the 50 s transient) inside the 1.2 m tube. Measured: 4e-4 and 1.16 m; before these
    defaults (first_order, k 0.2, no bound): 102 and tens of metres."""
    outcome, path = _run(_paper("comms.transmit.period=10"))
    assert outcome.last < 0.05, outcome
    assert path < 1.2


def test_without_the_thrust_bound_the_released_vehicle_leaves_its_tube():
    """AUV 1 released from its speed cap at 250 s, 17 units of gamma behind, every 20 s: unbounded, law (5) asks
    for a gamma_ddot of about 4 and the vehicle falls 1.44 m behind its point; bounded, 1.16 m."""
    bounded = _run(_paper("comms.transmit.period=20", "scenario.duration=300"))[1]
    unbounded = _run(_paper("comms.transmit.period=20", "scenario.duration=300", "saturation.correction=none"))[1]
    assert bounded < 1.2 < unbounded


def test_a_ring_of_five_on_30_s_tdma_frames_with_30_percent_bursty_loss_coordinates_with_the_defaults():
    """configs/examples/helix_ring_30s.toml up to its fault (290 s): from 23 units of gamma apart to under 2, in the
    tube; with the former defaults the same fleet is 150 apart at 224 s and diverges (issue 23, item 5)."""
    path = CONFIGS / "examples" / "helix_ring_30s.toml"
    scenario = parse_scenario(path.read_text(), str(path), ["scenario.duration=290"])
    outcome, error = _run(scenario)
    assert outcome.last < 2.0, outcome
    assert error < tube_radius(scenario)


def _run(scenario):
    """(coordination outcome, max path error after the report's transient) of an in-process run."""
    outcome = simulate(scenario)
    return outcome, outcome.path_error


def test_the_run_fits_k_to_the_links_own_losses_too():
    """The k a run uses (fleet.coupling_k) is fitted to the loop with its links' own losses (they were left out):
    the paper every 9 s with its two links into vehicle 1 losing 80 % runs with a smaller k than the lossless
    loop's 0.0841, and that k decays faster than 0.0841 on those links; every link at its own loss 0 under a fleet
    loss of 0.6 runs with the lossless loop's k (it ran with 0.0297, the 0.6 loop's)."""
    from supervisor.config.fleet import coupling_k

    first_order = ["comms.transmit.period=9", "coordination.predictor=first_order"]
    lossy = _paper(*first_order, "comms.links=[{sender=2,receiver=1,loss=0.8},{sender=3,receiver=1,loss=0.8}]")
    k = coupling_k(lossy)
    assert k < 0.08 and rate(_with_k(nominal_setting(lossy), k)) > rate(_with_k(nominal_setting(lossy), 0.0841))
    zeroed = "[" + ",".join(f"{{sender={s},receiver={r},loss=0.0}}" for s, r in ((1, 2), (2, 1), (1, 3), (3, 1))) + "]"
    zeroed_k = coupling_k(_paper(*first_order, "comms.loss=0.6", f"comms.links={zeroed}"))
    assert zeroed_k == pytest.approx(0.0841, abs=5e-4)

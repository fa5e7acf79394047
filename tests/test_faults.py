"""The fault schedule as pure functions: what acts on whom over each step, and how faults are written."""

from __future__ import annotations

import numpy as np
import pytest

from comms.records.run import Link
from supervisor.config.derived import active, intervals
from supervisor.config.scenario import fault_table, parse_scenario
from supervisor.errors import ScenarioError
from supervisor.plan.faults import _disturbances, _events_at, _network_at, _process_actions
from tests.conftest import CONFIGS

DT = 0.1


def scenario_with(*faults: str, on_loss: str = "abort"):
    text = (CONFIGS / "paper.toml").read_text()
    return parse_scenario(text, "s.toml", [f"scenario.on_vehicle_loss={on_loss}"], list(faults))


def test_a_fault_acts_on_its_steps_only_and_an_open_end_lasts_to_the_end():
    sc = scenario_with("kind=blackout,start=10,end=12", "kind=modem_silent,vehicle=2,start=5")
    blackout, silent = sc.faults[-2], sc.faults[-1]
    assert [active(blackout, t, DT) for t in (9.9, 10.0, 11.9, 12.0)] == [False, True, True, False]
    assert active(silent, 399.9, DT) and not active(silent, 4.9, DT)
    assert ("modem_silent", 5.0, 400.0) in intervals(sc)


def test_network_faults_shape_the_network_of_each_step():
    sc = scenario_with(
        "kind=link_down,sender=1,receiver=2,both=false,start=10,end=20",
        "kind=link_degraded,sender=1,receiver=3,extra_loss=0.5,extra_delay=0.3,start=10,end=20",
        "kind=link_degraded,sender=3,receiver=1,both=false,extra_loss=0.5,start=15,end=20",
        "kind=graph_switch,edges=[[1,2],[2,3]],start=30,end=40",
    )
    quiet = _network_at(sc, 5.0, DT)
    assert quiet.neighbours(1) == [2, 3] and not quiet.down and not quiet.degraded and not quiet.blackout
    busy = _network_at(sc, 16.0, DT)
    assert busy.down == (Link(1, 2),)  # one direction only
    assert busy.impairment(1, 2).lost == "link_down" and busy.impairment(2, 1).lost is None
    assert (busy.impairment(1, 3).extra_loss, busy.impairment(1, 3).extra_delay) == (0.5, 0.3)
    worse = busy.impairment(3, 1)
    assert (worse.extra_loss, worse.extra_delay) == pytest.approx((0.75, 0.3))  # two compose: 1 - 0.5 * 0.5
    switched = _network_at(sc, 35.0, DT)
    assert switched.neighbours(1) == [2] and switched.neighbours(3) == [2]
    assert _network_at(sc, 40.0, DT).neighbours(1) == [2, 3]  # back to the scenario's graph


def test_vehicle_faults_become_disturbances_of_that_vehicle_only():
    sc = scenario_with(
        "kind=frozen_gamma,vehicle=2,start=10,end=20",
        "kind=gamma_offset,vehicle=2,offset=1.5,start=10,end=20",
        "kind=clock_skew,vehicle=3,offset=-0.4,start=10,end=20",
    )
    two, three, one = (_disturbances(sc.faults, v, 12.0, DT) for v in (2, 3, 1))
    assert two.gamma_freeze and two.gamma_offset == 1.5 and two.clock_offset == 0.0
    assert three.clock_offset == -0.4 and not three.gamma_freeze
    assert one.gamma_dot_cap is None and not one.gamma_freeze  # the paper's cap starts at 150 s
    assert _disturbances(sc.faults, 1, 150.0, DT).gamma_dot_cap == 0.5


def test_fault_events_and_process_actions_come_at_the_step_boundaries():
    sc = scenario_with("kind=vehicle_kill,vehicle=2,start=10,end=13", "kind=broker_kill,start=20")
    assert [(e.kind, e.phase) for e in _events_at(sc.faults, 10.0, DT)] == [("vehicle_kill", "start")]
    assert [(a.action, a.target, a.vehicle) for a in _process_actions(sc.faults, 10.0, DT)] == [("kill", "vehicle", 2)]
    assert [(a.action, a.vehicle) for a in _process_actions(sc.faults, 13.0, DT)] == [("restart", 2)]
    assert [a.action for a in _process_actions(sc.faults, 20.0, DT)] == ["kill"]
    assert [a.action for a in _process_actions(sc.faults, 20.1, DT)] == ["restart"]  # a broker restarts a step later
    assert _process_actions(sc.faults, 10.1, DT) == []


def test_fault_specs_on_the_command_line_keep_lists_whole():
    assert fault_table("kind=graph_switch,edges=[[1,2],[2,3]],start=3") == {
        "kind": "graph_switch",
        "edges": [[1, 2], [2, 3]],
        "start": 3,
    }
    assert fault_table("kind=link_down, sender=1, receiver=2, both=false, start=1.5")["both"] is False


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("kind=teleport,start=1", r"faults\[1\]\.kind: .*'teleport'"),
        ("kind=link_down,sender=1,receiver=9,start=1", r"faults\[1\]\.receiver: no such vehicle .* got 9"),
        ("kind=link_down,sender=1,receiver=1,start=1", r"faults\[1\]\.receiver: a link joins two vehicles, got 1"),
        ("kind=blackout,start=5,end=4", r"faults\[1\]\.end: must be after start \(5\.0\), got 4\.0"),
        ("kind=graph_switch,edges=[[1,7]],start=1", r"faults\[1\]\.edges: not an edge .* got \[1, 7\]"),
        ("kind=vehicle_kill,start=1", r"faults\[1\]\.vehicle: "),
        ("start=1", r"faults\[1\]"),
        ("kind", r"--fault: expected KEY=VALUE"),
    ],
)
def test_bad_faults_are_one_line_errors_naming_the_field(spec, message):
    with pytest.raises(ScenarioError, match=message) as caught:
        scenario_with(spec)
    assert "\n" not in str(caught.value)


def test_phases_split_where_an_off_grid_fault_acts():
    """A fault at 0.33 s acts from the step at 0.3 s (active(), the faults table): the summary's phases split there
    too, not at 0.33 (a new user saw the table say 5.0 and the phases 5.05), written 0.3, not 3 x 0.1; its end
    likewise, 9.97 -> 10.0."""
    sc = scenario_with("kind=blackout,start=0.33,end=9.97")
    kind, start, end = intervals(sc)[-1]
    assert kind == "blackout"
    acting = [round(k * DT, 10) for k in range(200) if active(sc.faults[-1], k * DT, DT)]
    assert (start, end) == (acting[0], round(acting[-1] + DT, 10)) == (0.3, 10.0)


def test_a_phase_holds_every_step_its_fault_acts_on_whatever_the_step():
    """With a 0.3 s step a blackout at 0.95-2.0 s acts on steps 3-6 (0.9-1.8 s); its phase began at 0.9, and step
    3's time, 3 x 0.3 = 0.8999999999999999, fell before it: the phase lost its first step (the review)."""
    from supervisor.analysis.summary import Series, summarize

    text = (CONFIGS / "paper.toml").read_text()
    sc = parse_scenario(text, "s.toml", ["scenario.step=0.3", "scenario.duration=3.0", "faults=[]"],
                        ["kind=blackout,start=0.95,end=2.0"])  # fmt: skip
    steps = 10
    t = np.arange(steps, dtype=np.float64) * 0.3
    gamma = np.zeros((steps, 3))
    gamma[3:7, 0] = 1.0  # the blackout's steps alone disagree
    series = Series((1, 2, 3), t, gamma, np.zeros((steps, 3)), np.zeros((steps, 3)))
    phases = {p.name: p for p in summarize(series, 3.0, intervals(sc)[-1:], 0.0, 1.2, 0.01).phases}
    assert phases["during blackout"].max_coordination_error == 1.0
    assert phases["before faults"].max_coordination_error == phases["after faults"].max_coordination_error == 0.0


def test_a_kill_announces_its_restart_at_the_step_it_happens():
    """A kill on [7.05, 9.05) s acts from the step at 7.0 s and the vehicle is restarted at the step at 9.0 s; the
    kill said 'restarted at t = 9.1 s' (9.05 printed), the restart 'at t = 9.0 s' (a new user)."""
    sc = scenario_with("kind=vehicle_kill,vehicle=2,start=7.05,end=9.05")
    kill = _process_actions(sc.faults, 7.0, DT)
    assert [(a.action, a.until) for a in kill] == [("kill", 9.0)]
    assert [a.action for a in _process_actions(sc.faults, 9.0, DT)] == ["restart"]

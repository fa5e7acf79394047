"""The step plan (supervisor/plan/schedule.py) against the fault schedule asked step by step, and its change steps."""

from __future__ import annotations

import numpy as np
import pytest

from comms.records.records import Disturbances
from supervisor.config.scenario import parse_scenario
from supervisor.plan.faults import _disturbances, _events_at, _network_at, _process_actions
from supervisor.plan.schedule import Schedule
from tests.conftest import shortened
from tests.test_faults_e2e import apart, random_schedule


def _direct(sc, k):
    """What the engines asked for step k before the plan: each function called with t = k dt."""
    dt = sc.scenario.step
    t = k * dt
    dist = {i: d for i in sc.vehicle_ids if (d := _disturbances(sc.faults, i, t, dt)) != Disturbances()}
    return _events_at(sc.faults, t, dt), _process_actions(sc.faults, t, dt), _network_at(sc, t, dt), dist


@pytest.mark.parametrize("seed", range(12))
def test_plan_equals_the_schedule_asked_step_by_step(paper_text, seed):
    rng = np.random.default_rng(seed)
    fixed = ["kind=vehicle_kill,vehicle=2,start=3.05", "kind=broker_kill,start=7.0"]  # between grid points,
    # open-ended; the broker's default end: one step later. A random kill of the same process meeting them: left out
    faults = apart([*fixed, *random_schedule(rng, 30.0)])
    sc = parse_scenario(shortened(paper_text, 30.0), "s.toml", faults=faults)
    schedule = Schedule(sc)
    previous = _network_at(sc, -sc.scenario.step, sc.scenario.step)  # before the run: the scenario's graph
    for k in range(schedule.steps + 1):
        plan = schedule.plan(k)
        events, actions, network, dist = _direct(sc, k)
        assert (list(plan.events), list(plan.actions), plan.network, dict(plan.disturbances)) == (
            events,
            actions,
            network,
            dist,
        ), k
        assert plan.graph_changed == (network.edges != previous.edges)
        assert plan.final == (k == schedule.steps)
        previous = network


@pytest.mark.parametrize("seed", range(12))
def test_nothing_changes_inside_a_window(paper_text, seed):
    """next_change(k) is a promise: between k and it, no event, no action, the same network and disturbances."""
    sc = parse_scenario(
        shortened(paper_text, 30.0), "s.toml", faults=random_schedule(np.random.default_rng(seed), 30.0)
    )
    schedule = Schedule(sc)
    k = 0
    windows = 0
    while k < schedule.steps:
        end = schedule.next_change(k)
        assert k < end <= schedule.steps
        first = schedule.plan(k)
        for j in range(k + 1, end):
            inside = schedule.plan(j)
            assert not inside.events and not inside.actions and not inside.graph_changed, j
            assert (inside.network, inside.disturbances) == (first.network, first.disturbances), j
        k, windows = end, windows + 1
    assert windows == len(schedule.change_steps) - 1


def test_the_change_steps_are_where_faults_start_and_end(paper_text):
    sc = parse_scenario(
        shortened(paper_text, 30.0),
        "s.toml",
        faults=[
            "kind=blackout,start=2.0,end=2.96",
            "kind=broker_kill,start=10.0",
            "kind=frozen_gamma,vehicle=1,start=29.5",
        ],
    )
    schedule = Schedule(sc)
    # 2.96 ends with the step at 3.0 (half a step early: on the grid robustly); the broker restarts a step later;
    # an open end adds no change.
    assert schedule.change_steps == [0, 20, 30, 100, 101, 295, 300]
    assert schedule.next_change(0) == 20 and schedule.next_change(20) == 30 and schedule.next_change(295) == 300
    assert schedule.next_change(300) == 300


def test_a_plan_outside_the_run_is_refused(paper_text):
    schedule = Schedule(parse_scenario(shortened(paper_text, 1.0), "s.toml"))
    with pytest.raises(ValueError, match="outside the run"):
        schedule.plan(11)


def test_scheduled_alive(paper_text):
    sc = parse_scenario(shortened(paper_text, 10.0), "s.toml", faults=["kind=vehicle_kill,vehicle=2,start=1,end=2"])
    schedule = Schedule(sc)
    assert schedule.scheduled_alive(9) == [1, 2, 3]
    assert schedule.scheduled_alive(10) == [1, 3]
    assert schedule.scheduled_alive(20) == [1, 2, 3]


def test_a_graph_switch_at_the_start_is_a_change_of_step_0(paper_text):
    """Step 0 changes the graph if a switch is in force from the start: every engine records it at t = 0."""
    switched = parse_scenario(shortened(paper_text, 2.0), "s.toml", faults=["kind=graph_switch,edges=[[1,2]],start=0"])
    assert Schedule(switched).plan(0).graph_changed and Schedule(switched).plan(0).network.edges == ((1, 2),)
    assert not Schedule(parse_scenario(shortened(paper_text, 2.0), "s.toml")).plan(0).graph_changed

"""The clock's time windows, as pure decisions (supervisor.engine.windows), and the plan they rest on: inside
[k, Schedule.next_change(k)) nothing external changes but k and t."""

from __future__ import annotations

import pytest

from supervisor.config.scenario import load_scenario
from supervisor.engine.windows import window_end, worth_waiting
from supervisor.plan.schedule import Schedule
from tests.conftest import CONFIGS

FLEET = [1, 2, 3]


def test_no_report_yet_grants_one_step():
    assert window_end(0, 4000, FLEET, {}) == 1
    assert window_end(0, 4000, FLEET, {1: (5, 20), 2: (5, 20)}) == 1  # vehicle 3 unknown (restarted, say)


def test_the_window_ends_at_the_first_step_a_vehicle_may_transmit_at():
    reports = {1: (9, 19), 2: (9, 14), 3: (9, 30)}
    assert window_end(10, 4000, FLEET, reports) == 15  # steps 10 .. 14; vehicle 2 may transmit at 14
    assert window_end(10, 4000, [1, 3], reports) == 20  # vehicle 2 is dead: it does not count
    assert window_end(10, 4000, FLEET, {v: (9, 10) for v in FLEET}) == 11  # transmitting at every step


def test_the_window_stops_before_a_change_and_at_the_end():
    reports = {v: (9, 100) for v in FLEET}
    assert window_end(10, 13, FLEET, reports) == 13  # a fault starts at 13: steps 10 .. 12
    assert window_end(10, 11, FLEET, reports) == 11
    assert window_end(10, 40, FLEET, reports) == 40  # the run's end (next_change is at most the steps)


def test_a_stale_report_grants_one_step_and_longest_caps():
    assert window_end(10, 4000, FLEET, {v: (5, 8) for v in FLEET}) == 11  # they may transmit before 10
    assert window_end(10, 4000, FLEET, {v: (9, 100) for v in FLEET}, longest=1) == 11
    assert window_end(10, 4000, FLEET, {v: (9, 100) for v in FLEET}, longest=4) == 14


@pytest.mark.parametrize(
    ("reports", "change", "wait"),
    [
        ({}, 4000, False),  # nobody reported: nothing to wait for
        ({v: (8, 9) for v in FLEET}, 4000, False),  # every step: one step now or later
        ({1: (8, 9), 2: (0, 9), 3: (8, 30)}, 4000, False),  # vehicle 1 likely transmits at 10 anyway
        ({1: (8, 30), 2: (0, 9), 3: (8, 30)}, 4000, True),  # vehicle 2 transmits at 9, then waits: worth it
        ({1: (8, 30), 2: (0, 9), 3: (8, 30)}, 11, False),  # a change at 11: one step whatever it says
        ({1: (8, 10), 2: (0, 9), 3: (8, 30)}, 4000, False),  # vehicle 1 may transmit at 10
        ({v: (8, 30) for v in FLEET}, 4000, False),  # all fresh enough: the window is known
    ],
)
def test_worth_waiting_for_fresh_reports_only_when_they_could_lengthen_the_window(reports, change, wait):
    assert worth_waiting(10, change, FLEET, reports) is wait


@pytest.mark.parametrize("file", ["examples/every_fault.toml", "paper.toml"])
def test_inside_a_stretch_between_changes_only_k_and_t_change(file):
    """What the windows rest on: steps k+1 .. next_change(k)-1 bring no fault event, no kill or restart, no graph
    change, and the network and disturbances of step k."""
    schedule = Schedule(load_scenario(CONFIGS / file))
    k = 0
    while k < schedule.steps:
        change = schedule.next_change(k)
        assert k < change <= schedule.steps
        first = schedule.plan(k)
        for j in range(k + 1, change):
            plan = schedule.plan(j)
            assert not plan.events and not plan.actions and not plan.graph_changed
            assert plan.network == first.network and plan.disturbances == first.disturbances
        k = change
    assert schedule.next_change(schedule.steps) == schedule.steps

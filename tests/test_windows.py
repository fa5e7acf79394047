"""The clock's time windows, as pure decisions (supervisor.engine.windows), and the plan they rest on: inside
[k, Schedule.next_change(k)) nothing external changes but k and t."""

from __future__ import annotations

import pytest

from comms.records.messages import TICK_KEY
from supervisor.config.scenario import load_scenario
from supervisor.engine.clock import LONGEST_WINDOW, Clock
from supervisor.engine.windows import window_end, worth_waiting
from supervisor.plan.schedule import Schedule
from tests.conftest import CONFIGS, RecordingPublishers

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


# --- the clock's grants (supervisor.engine.clock.Clock), with a stand-in for the supervisor ------------------------


class Run:
    """What the clock drives (supervisor.engine.clock.Driven): who is alive, what they reported, what it said."""

    def __init__(self, reports: dict[int, tuple[int, int]], comms_up: bool = False) -> None:
        """comms_up: with a broker, lockstep ticks grant it spans (comms.broker.span); without, the supervisor's
        windows."""
        self.alive, self.comms_up, self._reports = list(FLEET), comms_up, reports
        self.recorded: list[tuple[str, float, dict]] = []

    @property
    def reports(self) -> dict[int, tuple[int, int]]:
        return self._reports

    def record(self, key: str, t: float, message: dict) -> None:
        self.recorded.append((key, t, message))

    def publish(self, key: str, t: float, message: dict) -> None:
        self.recorded.append((key, t, message))

    def pump(self, timeout: float) -> None:
        pass

    def carry_out(self, action: object, k: int) -> None:
        pass

    def grant(self, reach: int) -> None:
        self.granted = reach


def clock(mode: str = "lockstep", longest: int | None = None) -> tuple[Clock, RecordingPublishers]:
    pubs = RecordingPublishers()
    return Clock(load_scenario(CONFIGS / "paper.toml"), pubs, mode, 1e6, longest), pubs  # speed cap at 150-250 s


def test_the_clock_grants_a_window_and_logs_one_tick_per_step_of_it():
    """Without a broker (it is down: the supervisor hands the vehicles their ticks) the supervisor's own windows."""
    ticks, pubs = clock()
    run = Run({v: (9, 20) for v in FLEET})
    assert ticks.issue(run, 10) == 21
    [tick] = [message for key, message in pubs.messages if key == TICK_KEY]
    assert tick["k"] == 10 and tick["until"] == 21
    stepwise, _ = clock(longest=1)
    one_by_one = Run({v: (9, 20) for v in FLEET})
    assert [stepwise.issue(one_by_one, k) for k in range(10, 21)] == list(range(11, 22))
    assert run.recorded == one_by_one.recorded  # the log cannot tell
    assert all("until" not in message for _, _, message in run.recorded)


def test_the_clock_stops_a_window_before_a_fault_and_at_the_end():
    ticks, _ = clock()
    far = Run({v: (1490, 4000) for v in FLEET})
    assert ticks.issue(far, 1495) == 1500  # the speed cap starts at step 1500
    assert ticks.issue(far, 1500) == 1500 + LONGEST_WINDOW  # the cap ends it before the fault's end at 2500
    assert clock(longest=2000)[0].issue(far, 1500) == 2500
    assert ticks.issue(Run({v: (3990, 5000) for v in FLEET}), 3995) == 4000  # the run ends at step 4000
    assert ticks.issue(far, 4000) == 4001  # the final tick
    assert ticks.issue(Run({1: (9, 20), 2: (9, 20)}), 10) == 11  # vehicle 3 has not reported: it may transmit


def test_with_a_broker_the_clock_grants_it_the_span_up_to_the_next_change_and_logs_one_tick_per_step():
    """Lockstep with a broker: one grant for the whole stretch to the next change (comms.broker.span), nothing per step
    on the bus; the log gets, step by step as the supervisor reaches them, the ticks stepping one at a time gives."""
    ticks, pubs = clock()
    run = Run({v: (9, 10) for v in FLEET}, comms_up=True)
    assert ticks.issue(run, 10) == 1500  # the speed cap starts at step 1500
    [(key, grant)] = pubs.messages
    assert key == TICK_KEY and grant["k"] == 10 and grant["span"] == 1500 and grant["longest"] == LONGEST_WINDOW
    assert "until" not in grant and run.recorded == []  # the broker works out the windows, the log waits
    for k in range(10, 1500):
        ticks.record(run, k)
    stepwise, _ = clock(longest=1)
    one_by_one = Run({v: (9, 10) for v in FLEET}, comms_up=True)
    assert [stepwise.issue(one_by_one, k) for k in range(10, 1500)] == list(range(11, 1501))
    assert run.recorded == one_by_one.recorded and len(run.recorded) == 1490
    assert ticks.can_run_ahead(run, 1500)  # a fault starts there, no process is killed: the grant may go ahead
    assert ticks.issue(run, 1500) == 2500 and pubs.messages[-1][1]["vehicles"][0]["cap"] == 0.5


def test_a_vehicle_lost_inside_a_span_is_granted_away_from_the_next_step_on():
    ticks, pubs = clock()
    run = Run({}, comms_up=True)
    ticks.issue(run, 0)
    ticks.issue(run, 1500, ahead=True)
    ticks.record(run, 1200)
    run.alive = [1, 3]
    ticks.reissue(run)
    regrants = pubs.messages[2:]
    assert [(m["k"], m["span"], m["alive"]) for _, m in regrants] == [(1201, 1500, [1, 3]), (1500, 2500, [1, 3])]
    ticks.record(run, 1201)
    assert run.recorded[-1][2]["alive"] == [1, 3] and run.recorded[-1][2]["k"] == 1201


def test_realtime_keeps_one_step_per_tick():
    ticks, pubs = clock("realtime")
    ticks.begin()
    run = Run({v: (9, 20) for v in FLEET}, comms_up=True)
    assert ticks.issue(run, 10) == 11
    [(key, _, tick)] = run.recorded  # on the bus and in the log, as it always was
    assert key == TICK_KEY and "until" not in tick and tick["wall"] is not None and pubs.messages == []
    assert ticks.can_run_ahead(Run({}), 11) is False

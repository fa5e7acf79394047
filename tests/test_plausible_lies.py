"""The lies a scenario asks of a vehicle (gamma_offset, frozen_gamma) get through its readers only while the fault
acts (comms.records.plausible.Lie, from supervisor.config.plausibility): a liar scheduled for 10 s could send its lie
at any step of the run, and a frozen_gamma with no end allowed 51 x the run's duration. A transmission is judged at
its step (k dt, its send time), whatever time a skewed clock stamps on it.

    vehicle 2: gamma_offset -100 over [10, 20) s; frozen_gamma over [30, 40) s and [40, 50) s (one stuck run)

and every lie a scenario's faults make, run whole in-process (the Zenoh engine's readers check the same
transmissions: tests/test_plausibility.py runs both), is within the bounds at its step: none would be dropped.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from comms.records.bounded import cause_of
from comms.records.plausible import SLACK
from comms.records.records import Transmission
from comms.records.state import StateReport
from comms.records.stream import IMPLAUSIBLE
from supervisor.cli import main
from supervisor.config.fault_schema import FrozenGammaFault, GammaOffsetFault
from supervisor.config.plausibility import plausibility
from supervisor.config.scenario import load_scenario
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS
from tests.test_bus_records import DT, SCENARIO, state

FAULTS = (
    GammaOffsetFault(kind="gamma_offset", vehicle=2, offset=-100.0, start=10.04, end=20.0),  # from step 100: 10.0 s
    FrozenGammaFault(kind="frozen_gamma", vehicle=2, start=30.0, end=40.0),
    FrozenGammaFault(kind="frozen_gamma", vehicle=2, start=40.0, end=50.0),
)
BOUNDS = plausibility(SCENARIO.model_copy(update={"faults": FAULTS}))[2]
HONEST = plausibility(SCENARIO)[2]


def sent(k: int, gamma: float, skew: float = 0.0) -> tuple[Transmission, StateReport]:
    """Vehicle 2's transmission of step k with this gamma (its state's: 4.25), stamped skew s off its send time."""
    report = StateReport.from_message(state(k), 2)
    return Transmission(2, k, k * DT, gamma, 0.98, report.position, (1.2, 0.1, 0.0), k * DT + skew), report


def refused(k: int, gamma: float, skew: float = 0.0) -> bool:
    tx, report = sent(k, gamma, skew)
    try:
        BOUNDS.check_tx(tx, report, DT)
    except ValueError as exc:
        assert cause_of(exc) == IMPLAUSIBLE
        return True
    return False


@pytest.mark.parametrize(
    ("k", "lied"), [(100, False), (150, False), (199, False), (99, True), (200, True), (500, True)]
)
def test_an_offset_gets_through_only_while_its_fault_acts(k: int, lied: bool) -> None:
    """The fault acts from half a step before its start (10.04 s: from step 100) to half a step before its end."""
    assert refused(k, 4.25 - 100.0) is lied
    assert not refused(k, 4.25)  # the truth, always


def test_a_skewed_stamp_does_not_move_the_window() -> None:
    assert not refused(150, 4.25 - 100.0, skew=-100.0) and refused(500, 4.25 - 100.0, skew=-350.0)


def test_a_frozen_reading_may_lag_by_what_gamma_moved_since_it_stuck() -> None:
    """Two frozen_gamma faults that meet are one stuck run (the reading stays the first step's): at 45 s, 15 s of
    drift; outside it, or further than the drift so far, the same lie is dropped."""
    drift = BOUNDS.gamma_dot * 14.0 + SLACK  # within 15 s of drift (with the step's own bound on top)
    assert not refused(450, 4.25 - drift) and not refused(450, 4.25 + drift)
    assert refused(350, 4.25 - drift)  # 5 s in: beyond what gamma moved since step 300
    assert refused(500, 4.25 - drift) and refused(250, 4.25 - drift)  # after the stuck run, before it


def test_an_honest_vehicle_is_allowed_no_lie() -> None:
    assert HONEST.lie(150, DT) == 0.0 and BOUNDS.lie(150, DT) == pytest.approx(100.0)
    assert BOUNDS.lie(0, DT) == 0.0 and BOUNDS.lie(499, DT) == pytest.approx(BOUNDS.gamma_dot * 19.9)


# On the five-vehicle line of the lying-vehicle studies (docs/resilience.md): a liar killed and restarted, a stuck
# sensor killed and restarted within its fault, a second liar on a skewed clock, lies overlapping.
LIARS = [
    "faults=[{kind='gamma_offset',vehicle=1,offset=5.0,start=20.0},{kind='vehicle_kill',vehicle=1,start=40.0,end=50.0},"
    "{kind='frozen_gamma',vehicle=2,start=20.0},{kind='vehicle_kill',vehicle=2,start=40.0,end=50.0},"
    "{kind='gamma_offset',vehicle=3,offset=-3.0,start=30.0,end=70.0},{kind='clock_skew',vehicle=3,offset=-0.5,"
    "start=25.0},{kind='gamma_offset',vehicle=2,offset=2.0,start=60.0,end=80.0}]",
    "scenario.duration=100",
]


@pytest.mark.parametrize(("config", "sets"), [("examples/every_fault.toml", []), ("paper.toml", LIARS)],
                         ids=["every_fault", "liars"])  # fmt: skip
def test_no_lie_the_scenario_asks_for_is_beyond_its_bounds(config: str, sets: list[str], tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    args = [arg for value in sets for arg in ("--set", value)]
    assert main(["run", str(CONFIGS / config), "--engine", "inprocess", "--out", str(out), "--quiet", *args]) == 0
    sc = load_scenario(CONFIGS / config, sets)
    bounds, dt = plausibility(sc), sc.scenario.step
    states, sent = {}, []
    for topic, _, message in read_messages(out):
        if topic.endswith("/state"):
            report = StateReport.from_message(message, message["vehicle"])
            states[(report.vehicle, report.k)] = report
        elif topic.endswith("/tx"):
            sent.append(Transmission.from_message(message, message["sender"]))
    lies = [tx for tx in sent if abs(tx.gamma - states[(tx.sender, round(tx.t / dt))].gamma) > 1.0]
    assert len(lies) > 100  # the scenario's lies were told
    for tx in sent:
        bounds[tx.sender].check_tx(tx, states[(tx.sender, round(tx.t / dt))], dt)


def test_stuck_runs_starting_together_one_without_an_end_are_one_run():
    """Two frozen_gamma faults on one vehicle from the same step, one open-ended: sorting (first, end) compared an
    end of None with a number (TypeError: the Zenoh engine's readers could not start; a review)."""
    from supervisor.config.derived import stuck_spans

    faults = [
        FrozenGammaFault(kind="frozen_gamma", vehicle=2, start=10.0),
        FrozenGammaFault(kind="frozen_gamma", vehicle=2, start=10.0, end=20.0),
    ]
    assert stuck_spans(faults, 2, 0.1) == [(100, None)]

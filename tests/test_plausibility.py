"""Plausibility (issue 29 item 2): a state beyond what the vehicle's own model and the step allow is dropped by the
intake and the broker as the vehicle's fault; the bounds (supervisor.config.plausibility) are generous enough that no
legitimate run comes near them; a stream's replayed steps and floods never reach the log (item 1)."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import msgspec
import pytest

from comms.broker.broker import Broker
from comms.bus.bus import Received
from comms.records.bounded import cause_of
from comms.records.messages import TICK_KEY, encode, state_key, tick_message, vehicle_of_key
from comms.records.plausible import Plausible
from comms.records.records import Transmission
from comms.records.state import StateReport
from comms.records.stream import BEYOND_WINDOW, FAULTY, IMPLAUSIBLE, REPLAYED
from supervisor.cli import main
from supervisor.config.broker_start import broker_start
from supervisor.config.plausibility import plausibility
from supervisor.config.scenario import load_scenario
from supervisor.engine.intake import Intake
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, RecordingPublishers
from tests.test_bus_records import DT, SCENARIO, Capture, state

BOUNDS = plausibility(SCENARIO)[2]
EVERY_CONFIG = sorted([*CONFIGS.glob("*.toml"), *(CONFIGS / "examples").glob("*.toml")])


def report(k: int, **changes: object) -> StateReport:
    return StateReport.from_message(state(k, **changes), 2)


@pytest.mark.parametrize(
    "changes",
    [{"gamma_dot": 1e30}, {"gamma": 1e30}, {"position": [1e5, 0.0, 0.0]}, {"velocity": [BOUNDS.speed * 1.01, 0, 0]}],
    ids=["gamma_dot", "gamma jump", "position jump", "speed"],
)
def test_a_state_beyond_its_vehicles_bounds_is_implausible(changes: dict[str, object]) -> None:
    before = report(1)
    BOUNDS.check(report(2), before, DT)  # the same vehicle, one step on: plausible
    with pytest.raises(ValueError) as refused:
        BOUNDS.check(report(2, **changes), before, DT)
    assert cause_of(refused.value) == IMPLAUSIBLE and "vehicle 2" in str(refused.value)


def test_the_bounds_come_from_the_vehicles_top_speed_and_path() -> None:
    """REMUS 100: 2.5 m/s at full thrust, twice that as the bound; gamma_dot: ten times what that speed gives."""
    assert Plausible(BOUNDS.speed, BOUNDS.ground_speed, BOUNDS.gamma_dot) == BOUNDS
    assert BOUNDS.speed == pytest.approx(5.0, rel=0.01) and 10 < BOUNDS.gamma_dot < 1000


def test_a_start_at_the_schemas_largest_body_velocity_is_plausible(tmp_path: Path) -> None:
    """[-5, 5, -5] m/s (each axis at its bound, 8.66 m/s) was refused at step 0 on the Zenoh engine: 'speed 8.66 m/s
    above its 5 m/s'. The vehicle only slows from its start: the bound takes it. (Its drag wants a short step:
    tests/test_fuzz_inputs.py's STIFF_STEP.)"""
    fast = ["vehicles.0.velocity=[-5.0, 5.0, -5.0]", "scenario.duration=1.0", "scenario.step=0.01", "faults=[]"]
    assert plausibility(load_scenario(CONFIGS / "paper.toml", fast))[1].speed >= math.sqrt(75.0)
    args = [a for o in fast for a in ("--set", o)]
    assert main(["run", str(CONFIGS / "paper.toml"), *args, "--out", str(tmp_path / "r.mcap"), "--quiet"]) == 0


def intake() -> tuple[Intake, Capture]:
    rec = Capture()
    return Intake(SCENARIO, rec, None), rec  # type: ignore[arg-type]  # Capture does what a Recorder is asked


def test_replayed_steps_and_a_flood_never_reach_the_log_and_are_counted(caplog: pytest.LogCaptureFixture) -> None:
    taking, rec = intake()
    caplog.set_level(logging.DEBUG)
    for k in (0, 1, 2):
        taking.take(Received(state_key(2), encode(state(k))), 0.0)
        taking.take(Received(state_key(2), encode(state(max(0, k - 1)))), 0.0)  # each step followed by an older one
    for _ in range(10_000):  # a flood of copies of step 0
        taking.take(Received(state_key(2), encode(state(0))), 0.0)
    states = [r for r in rec.records if r[0] == state_key(2)]
    assert [orjson_k(r[2]) for r in states] == [0, 1, 2]
    assert taking.drops.by_cause == {REPLAYED: 3 + 10_000} and taking.malformed == {state_key(2): 10_003}
    assert len([r for r in caplog.records if "dropped" in r.getMessage()]) <= 21  # a bounded log, not a flood


def orjson_k(data: bytes) -> int:
    return int(msgspec.json.decode(data)["k"])


def test_an_implausible_state_is_the_vehicles_fault_and_what_follows_from_it_is_dropped() -> None:
    taking, rec = intake()
    taking.take(Received(state_key(2), encode(state(0))), 0.0)
    taking.take(Received(state_key(2), encode(state(1, gamma=1e30, gamma_dot=1e30))), 0.0)
    assert [vid for vid, _ in taking.new_faults()] == [2] and taking.new_faults() == []  # told once
    taking.take(Received(state_key(2), encode(state(2))), 0.0)
    assert taking.drops.by_cause == {IMPLAUSIBLE: 1, FAULTY: 1} and len(rec.records) == 1
    assert "implausible" in taking.waiting_for(1, [1, 2, 3]) and "vehicle 1, vehicle 2" in taking.waiting_for(1, [1, 2])


def test_the_broker_lets_no_replay_or_implausible_state_into_the_channel() -> None:
    start = broker_start(SCENARIO, 0)
    broker = Broker(start.core, SCENARIO.vehicle_ids, RecordingPublishers(), DT)
    for k in (0, 1):  # steps 0 and 1 may come (a vehicle steps on a tick)
        broker.take(TICK_KEY, encode(tick_message(k, k * DT, False)))
    broker.take(state_key(2), encode(state(0)))
    broker.take(state_key(2), encode(state(0)))
    broker.take(state_key(2), encode(state(1, gamma_dot=1e30)))
    broker.take(state_key(2), encode(state(5)))
    assert broker.books.drops.by_cause == {REPLAYED: 1, IMPLAUSIBLE: 1, BEYOND_WINDOW: 1}
    assert [list(by_vehicle) for by_vehicle in broker.books.states.values()] == [[2]]


@pytest.mark.parametrize("config", EVERY_CONFIG, ids=[p.stem for p in EVERY_CONFIG])
def test_no_legitimate_run_comes_near_the_bounds(config: Path, tmp_path: Path) -> None:
    """Every config (the first 30 s, in-process: the same numbers as over Zenoh, tests/test_bit_identical.py) stays
    well inside its bounds: at most half of each, where 1e30 is beyond by 28 orders of magnitude."""
    out = tmp_path / "run.mcap"
    assert main(["run", str(config), "--engine", "inprocess", "--out", str(out), "--quiet",
                 "--set", "scenario.duration=30"]) == 0  # fmt: skip
    sc = load_scenario(config)
    bounds, previous, dt = plausibility(sc), dict[int, StateReport](), sc.scenario.step
    half = {vid: Plausible(b.speed / 2, b.ground_speed / 2, b.gamma_dot / 2, b.lies) for vid, b in bounds.items()}
    states, sent = {}, []
    for topic, _, message in read_messages(out):
        owned = vehicle_of_key(topic)
        if owned is not None and owned[1] == "state":
            now = StateReport.from_message(message, owned[0])
            half[now.vehicle].check(now, previous.get(now.vehicle), dt)
            previous[now.vehicle] = states[(now.vehicle, now.k)] = now
        elif owned is not None and owned[1] == "tx":
            sent.append(Transmission.from_message(message, owned[0]))
    assert previous and all(math.isfinite(r.gamma) for r in previous.values())
    for tx in sent:  # each against its step's state: the scenario's own lies (every_fault's) within the bounds
        half[tx.sender].check_tx(tx, states[(tx.sender, round(tx.t / dt))], dt)


LIES = ["faults=[{kind='gamma_offset',vehicle=2,offset=100.0,start=5.0},{kind='frozen_gamma',vehicle=3,start=5.0}]"]


def test_the_lies_a_scenario_asks_for_are_carried_by_both_engines_alike(tmp_path: Path) -> None:
    """A gamma_offset or frozen_gamma fault makes the vehicle transmit a gamma other than its state's on purpose:
    the Zenoh engine's readers dropped each such transmission as implausible (its neighbours never heard the lie
    that the in-process engine delivered); both now record the same transmissions, none dropped."""
    scenario = tmp_path / "paper.toml"
    scenario.write_text((CONFIGS / "paper.toml").read_text())
    logged = {}
    for engine in ("inprocess", "zenoh"):
        out = tmp_path / f"{engine}.mcap"
        sets = ["--set", "scenario.duration=15", "--set", LIES[0]]
        assert main(["run", str(scenario), "--engine", engine, "--out", str(out), "--quiet", *sets]) == 0
        records = [(topic, t, str(m)) for topic, t, m in read_messages(out) if topic.endswith(("/tx", "/state"))]
        logged[engine] = sorted(records)  # each engine logs a step's vehicles in the order they came
    assert logged["inprocess"] == logged["zenoh"]
    lies = [m for topic, t, m in logged["zenoh"] if topic == "cpf/vehicle/2/tx" and t >= 5_000_000_000]  # ns
    assert len(lies) == 100


def test_a_state_beyond_the_steps_the_clock_granted_is_dropped() -> None:
    taking, rec = intake()
    taking.granted = 2  # the clock granted steps 0 and 1
    taking.take(Received(state_key(2), encode(state(1))), 0.0)
    taking.take(Received(state_key(2), encode(state(2))), 0.0)
    assert taking.drops.by_cause == {BEYOND_WINDOW: 1} and len(rec.records) == 1


def test_a_step_far_beyond_the_run_is_named_alike_by_the_supervisor_and_the_broker() -> None:
    """Step 10^7 of a 400 s run: the broker dropped it as 'beyond the window' (the clock's), the supervisor as
    'malformed' (the run's bounds, checked first): two names for one forgery in one summary line (session 32)."""
    taking, _ = intake()
    taking.granted = 2
    taking.take(Received(state_key(2), encode(state(10**7))), 0.0)
    broker = Broker(broker_start(SCENARIO, 0).core, SCENARIO.vehicle_ids, RecordingPublishers(), DT)
    broker.take(TICK_KEY, encode(tick_message(0, 0.0, False)))
    broker.take(state_key(2), encode(state(10**7)))
    assert taking.drops.by_cause == broker.books.drops.by_cause == {BEYOND_WINDOW: 1}


def test_a_plausible_state_carrying_an_absurd_transmission_loses_the_transmission() -> None:
    """gamma 1e30 in the transmission only (issue 29: 'its tx too'): the neighbours never hear it; the state counts."""
    tx = {"sender": 2, "seq": 1, "t": 0.0, "gamma": 1e30, "gamma_dot": 0.98, "position": [1.0, -2.0, 3.0],
          "velocity": [1.2, 0.1, 0.0]}  # fmt: skip
    taking, rec = intake()
    taking.take(Received(state_key(2), encode({**state(0), "tx": tx})), 0.0)
    assert taking.drops.by_key == {"cpf/vehicle/2/tx": 1} and taking.drops.by_cause == {IMPLAUSIBLE: 1}
    assert [r[0] for r in rec.records] == [state_key(2)]
    broker = Broker(broker_start(SCENARIO, 0).core, SCENARIO.vehicle_ids, RecordingPublishers(), DT)
    broker.take(TICK_KEY, encode(tick_message(0, 0.0, False)))  # a vehicle steps on a tick
    broker.take(state_key(2), encode({**state(0), "tx": tx}))
    assert broker.books.drops.by_cause == {IMPLAUSIBLE: 1} and broker.books.states[0][2][1] is None


def test_a_transmission_not_at_its_step_s_time_is_dropped_by_both_readers() -> None:
    """A forged t (the channel times the packet from it; an early one would arrive before it was sent) loses the
    transmission, intake and broker alike (comms.records.stream.at_step_time); the state counts."""
    tx = {"sender": 2, "seq": 1, "t": 0.3, "gamma": 0.5, "gamma_dot": 0.98, "position": [1.0, -2.0, 3.0],
          "velocity": [1.2, 0.1, 0.0]}  # fmt: skip
    message = {**state(0), "tx": tx}  # step 0: t = 0
    taking, rec = intake()
    taking.take(Received(state_key(2), encode(message)), 0.0)
    assert taking.drops.by_key == {"cpf/vehicle/2/tx": 1} and [r[0] for r in rec.records] == [state_key(2)]
    for t, dropped in ((0.3, 1), (0.0, 0)):  # at its step's time: kept
        broker = Broker(broker_start(SCENARIO, 0).core, SCENARIO.vehicle_ids, RecordingPublishers(), DT)
        broker.take(TICK_KEY, encode(tick_message(0, 0.0, False)))  # a vehicle steps on a tick
        broker.take(state_key(2), encode({**message, "tx": {**tx, "t": t}}))
        assert broker.books.drops.total == dropped and (broker.books.states[0][2][1] is None) == bool(dropped)

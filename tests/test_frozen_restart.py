"""A stuck gamma sensor keeps its reading through a restart of the vehicle's process (frozen_gamma: "the gamma it had
at start" of the fault): the reading is the sensor's, so the state message carries it while it is stuck and a
restarted process (supervisor.config.fleet.restarted_node, every engine's) takes it up again, if the same stuck run
still holds then. A restarted vehicle broadcast its gamma at the restart instead (45.08 for 20.38, a researcher).

    paper.toml, vehicle 2: frozen_gamma from 10 s; vehicle_kill 20-30 s
"""

from __future__ import annotations

from pathlib import Path

import pytest

from supervisor.cli import main
from supervisor.config.fault_schema import FrozenGammaFault, GammaOffsetFault
from supervisor.config.fleet import restarted_node, vehicle_config
from supervisor.config.scenario import load_scenario
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS
from tests.test_bus_records import SCENARIO, state

FAULTS = "faults=[{kind='frozen_gamma',vehicle=2,start=10.0},{kind='vehicle_kill',vehicle=2,start=20.0,end=30.0}]"


def test_a_restarted_vehicle_keeps_broadcasting_the_reading_its_sensor_stuck_at(tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    sets = ["--set", FAULTS, "--set", "scenario.duration=40"]
    assert main(["run", str(CONFIGS / "paper.toml"), "--engine", "inprocess", "--out", str(out), "--quiet", *sets]) == 0
    sent = {round(m["t"], 1): m for topic, _, m in read_messages(out) if topic == "cpf/vehicle/2/tx"}
    stuck = sent[10.0]
    assert sent[9.9]["gamma"] != stuck["gamma"]
    after = [m for t, m in sent.items() if t >= 10.0]
    assert [t for t, m in sent.items() if 20.0 <= t < 30.0] == []  # dead
    assert len(after) == 200 and max(after, key=lambda m: m["t"])["t"] == pytest.approx(39.9)
    assert {(m["gamma"], m["gamma_dot"]) for m in after} == {(stuck["gamma"], stuck["gamma_dot"])}


def restarted_frozen(*faults: FrozenGammaFault | GammaOffsetFault) -> tuple[float, float] | None:
    """Vehicle 2 restarted at step 300 from its state of step 199, which says its sensor stuck at (7.5, 0.5)."""
    cfg = vehicle_config(SCENARIO, 2, 0)
    node = restarted_node(cfg, state(199, frozen=[7.5, 0.5]), 4, 300, 0.1, faults)
    return None if node.frozen is None else (node.frozen.gamma, node.frozen.gamma_dot)


def frozen(start: float, end: float | None = None) -> FrozenGammaFault:
    return FrozenGammaFault(kind="frozen_gamma", vehicle=2, start=start, end=end)


def test_the_reading_is_taken_up_only_while_the_same_stuck_run_holds() -> None:
    assert restarted_frozen(frozen(10.0)) == (7.5, 0.5)
    assert restarted_frozen(frozen(10.0, 25.0), frozen(25.0, 40.0)) == (7.5, 0.5)  # they meet: one stuck run
    assert restarted_frozen(frozen(10.0, 25.0), frozen(26.0)) is None  # a new one: it sticks at its restart
    assert restarted_frozen(frozen(25.0)) is None  # stuck while it was down: likewise
    assert restarted_frozen(frozen(10.0, 30.0)) is None  # over by its restart


def test_the_state_message_carries_the_reading_only_while_stuck(tmp_path: Path) -> None:
    out = tmp_path / "run.mcap"
    sets = ["--set", FAULTS, "--set", "scenario.duration=12"]
    assert main(["run", str(CONFIGS / "paper.toml"), "--engine", "inprocess", "--out", str(out), "--quiet", *sets]) == 0
    states = {m["k"]: m for topic, _, m in read_messages(out) if topic == "cpf/vehicle/2/state"}
    assert "frozen" not in states[99] and states[100]["frozen"] == [states[100]["gamma"], states[100]["gamma_dot"]]
    assert states[119]["frozen"] == states[100]["frozen"]
    assert load_scenario(CONFIGS / "paper.toml", [FAULTS]).faults[0].kind == "frozen_gamma"

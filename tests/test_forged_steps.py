"""A compromised vehicle's steps out of turn: whoever holds vehicle 2's credential publishes, on its state key and
ahead of its real step message, steps it has not taken yet. Every reader drops them (counted), and the fleet goes on.

    supervisor's router <--- vehicles 1, 3, 4, 5, comms broker (processes of the run)
            ^
            +---- vehicle 2, served in this test's process on its own credential; its publishers slip the forged
                  steps in just ahead of one of its step messages (same session: they arrive first, every time)

The forgeries are vehicle 2's own last state moved on to the next steps (plausible), with its transmission's gamma
+ 5: what a researcher's forger sent in a realtime run (5 vehicles, a complete graph), which stalled the whole fleet.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from comms.bus.access import client_config, read_credential
from comms.bus.bus import Extras, Publishers, free_port, serve
from comms.records.messages import COMMS_STEP_KEY, Message, rx_key, state_key, vehicle_alive_key
from supervisor.config.scenario import parse_scenario
from supervisor.config.vehicle_start import vehicle_starts
from tests.procs import cpf, start_cpf, wait_for_file
from tests.run_digest import digest
from vehicles.node import _Vehicle

pytestmark = [pytest.mark.integration, pytest.mark.e2e]
ATTACK_AT = 30  # the first step message of vehicle 2 ending at or after this step is preceded by the forgeries
FORGED_STEPS = 3
WAIT = 20.0  # s: a bound on what does come, never reached when things work
DT = 0.1  # the scenario's step
VEHICLES = (1, 2, 3, 4, 5)
SCENARIO = """
[scenario]
name = "forged_steps"
duration = 8.0
step = 0.1
seed = 0
on_vehicle_loss = "continue"

[vehicle]
preset = "remus100"
actuators = "ideal"

[coordination]
k = 0.2
k2 = 1.0
v_r = 1.0
law = "corrected"

[graph]
edges = [[1, 2], [1, 3], [1, 4], [1, 5], [2, 3], [2, 4], [2, 5], [3, 4], [3, 5], [4, 5]]
""" + "".join(
    f"""
[[vehicles]]
id = {v}
position = [0.0, {20.0 * (v - 1)}, -10.0]
path = {{ type = "line", start = [0.0, {20.0 * (v - 1)}, -10.0], velocity = [1.0, 0.0, 0.0] }}
gamma0 = {float(v % 3)}
"""
    for v in VEHICLES
)


def forgeries(real: Message) -> list[Message]:
    """Steps k+1 .. k+FORGED_STEPS of the vehicle whose real step message ends at step k: its state of k moved on in
    time (plausible), its transmission (if any) told with gamma + 5."""
    k, out = int(real["k"]), []
    for j in range(k + 1, k + 1 + FORGED_STEPS):
        state = {key: value for key, value in real.items() if key not in ("tx", "rx", "next_tx", "earlier")}
        tx = real.get("tx")
        if isinstance(tx, dict):
            tx = {**tx, "t": j * DT, "gamma": float(tx["gamma"]) + 5.0}
        out.append({**state, "k": j, "t": j * DT, "tx": tx, "rx": None})
    return out


class Forging(Publishers):
    """Vehicle 2's publishers, the forgeries put just ahead of its first step message ending at ATTACK_AT or after."""

    def __init__(self, real: Publishers) -> None:
        self.real, self.forged = real, 0

    def put(self, key: str, message: Message) -> None:
        if key == state_key(2) and not self.forged and int(message["k"]) >= ATTACK_AT:
            for forged in forgeries(message):
                self.real.put(key, forged)
                self.forged += 1
        self.real.put(key, message)


@contextmanager
def vehicle_2_forging(scenario: Any, endpoint: str, credential: Path) -> Iterator[list[Forging]]:
    """Vehicle 2, as `cpf vehicle --id 2` serves it, in a thread of this process, publishing through Forging."""
    start = vehicle_starts(scenario, [2])[0]
    extras = Extras(None, client_config(read_credential(credential)), credentials=True)
    made: list[Forging] = []

    def handler(publishers: Publishers) -> _Vehicle:
        made.append(Forging(publishers))
        return _Vehicle(start.cfg, start.radio, start.initial, start.neighbours, start.dt, made[0], 0)

    keys = (COMMS_STEP_KEY, rx_key(2))
    thread = threading.Thread(
        target=serve, args=("vehicle 2", [endpoint], keys, vehicle_alive_key(2), handler, start.hello, extras)
    )
    thread.start()
    try:
        yield made
    finally:
        thread.join(timeout=30)  # it leaves on the run's stop message, or as the supervisor's token goes


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_steps_forged_ahead_of_a_vehicles_own_are_dropped_and_the_fleet_goes_on(tmp_path: Path, clock: str) -> None:
    (tmp_path / "forged.toml").write_text(SCENARIO)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    pacing = ["--clock", "realtime", "--speed", "4"] if clock == "realtime" else []
    argv = ["run", "forged.toml", "--listen", endpoint, "--remote", "2", "--credentials-dir", "creds", "--quiet"]
    run = start_cpf([*argv, *pacing, "--out", "run.mcap", "--metrics", "m.json"], tmp_path)
    try:
        wait_for_file(tmp_path / "creds" / "vehicle-2.json", timeout=WAIT)
        with vehicle_2_forging(parse_scenario(SCENARIO), endpoint, tmp_path / "creds" / "vehicle-2.json") as made:
            _, err = run.communicate(timeout=150)
    finally:
        run.kill()
    assert run.returncode == 0, err
    assert made[0].forged == FORGED_STEPS
    metrics = json.loads((tmp_path / "m.json").read_text())
    assert metrics["malformed"]["supervisor"] == {state_key(2): FORGED_STEPS}, metrics["malformed"]
    assert metrics["malformed"]["broker"] == {state_key(2): FORGED_STEPS}, metrics["malformed"]  # whose key
    if clock == "lockstep":  # nothing forged reached the log or the channel: the records of the run undisturbed
        ref = cpf("run", "forged.toml", "--engine", "inprocess", "--out", "ref.mcap", "--quiet", cwd=tmp_path)
        assert ref.returncode == 0, ref.stderr
        assert digest(tmp_path / "run.mcap") == digest(tmp_path / "ref.mcap")

"""A vehicle process the supervisor starts is handed what it serves (vehicles.start) instead of loading the scenario:
it never imports pydantic (issue 15: <= 60 MB per vehicle process), yet answers the hello with the supervisor's
digests; a file that is not such a hand-over is refused with a one-line error."""

from __future__ import annotations

import os
import subprocess
import threading
from pathlib import Path
from typing import Any

import pytest
import zenoh

from comms.bus.bus import free_port, open_session
from comms.bus.handover import write_private
from comms.records.messages import STOP_KEY, SUPERVISOR_ALIVE, Hello, encode, vehicle_alive_key
from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_digest import digest, section_digests
from supervisor.config.vehicle_start import vehicle_starts
from supervisor.engine import supervisor as supervisor_module
from supervisor.engine.launch import BusOptions, Launch
from supervisor.engine.startup import ask_hello
from supervisor.engine.supervisor import Roster, Supervisor
from tests.conftest import CONFIGS
from tests.procs import CPF

PAPER = CONFIGS / "paper.toml"  # gamma0 = "closest": the search the supervisor now does for its children
WAIT = 60.0  # s: generous bounds, never reached when things work


class _Procs:
    def __init__(self) -> None:
        self.spawned: list[tuple[str, list[str]]] = []

    def spawn(self, name: str, argv: list[str], control_env: str | None = None) -> None:
        self.spawned.append((name, argv))


def _spawned(per_process: int, endpoint: str, tmp_path: Path, monkeypatch: Any) -> list[tuple[str, list[str]]]:
    """The command lines the supervisor starts the paper fleet's vehicle processes with (no bus of its own)."""
    monkeypatch.setattr(supervisor_module, "cores", lambda: 2)
    run = Supervisor.__new__(Supervisor)
    bus = BusOptions()
    bus.per_process = per_process
    run.sc = load_scenario(PAPER, (), ())
    run.launch = Launch(PAPER, endpoint, bus, 0, tmp_path)
    run.procs, run.roster, run.hosted = _Procs(), Roster(), {}  # type: ignore[assignment]
    run.spawn_vehicles()
    return run.procs.spawned  # type: ignore[attr-defined]


def _maps(pid: int) -> str:
    return Path(f"/proc/{pid}/maps").read_text()


@pytest.mark.parametrize("per_process", [1, 2])  # processes of one vehicle; a host of two and one of one
def test_a_spawned_vehicle_process_loads_no_pydantic_and_proves_the_supervisors_scenario(
    per_process: int, tmp_path: Path, monkeypatch: Any
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    spawned = _spawned(per_process, endpoint, tmp_path, monkeypatch)
    expected = section_digests(load_scenario(PAPER, (), ()))
    keys = {vehicle_alive_key(v) for v in (1, 2, 3)}
    with open_session("router", listen=[endpoint]) as session:
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)
        came: set[str] = set()
        all_came = threading.Event()

        def on_token(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.PUT:
                came.add(str(sample.key_expr))
                if came >= keys:
                    all_came.set()

        watcher = session.liveliness().declare_subscriber("cpf/alive/vehicle/*", on_token)
        env = {k: v for k, v in os.environ.items() if not k.startswith("CPF_")}
        children = [subprocess.Popen(argv, env=env, stdin=subprocess.DEVNULL) for _, argv in spawned]
        try:
            assert all_came.wait(WAIT), f"came alive: {sorted(came)}"
            for vid in (1, 2, 3):
                got = ask_hello(session, vehicle_alive_key(vid), timeout=10.0)
                assert got == Hello(f"vehicle {vid}", digest(expected), expected)
            for child in children:
                maps = _maps(child.pid)
                assert "zenoh" in maps  # what it should have: the test reads the right process
                assert "pydantic_core" not in maps
                assert "site-packages/scipy/" not in maps  # the search for "closest" is the supervisor's
        finally:
            session.put(STOP_KEY, encode({"t": 0.0, "reason": "end of run"}))
            codes = [child.wait(WAIT) for child in children]
            watcher.undeclare()
            token.undeclare()
    assert codes == [0] * len(children)
    assert [name for name, _ in spawned] == (["vehicle 1", "vehicle 2", "vehicle 3"] if per_process == 1
                                             else ["vehicles 1,2", "vehicle 3"])  # fmt: skip


def _refused(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([CPF, "vehicle", str(PAPER), *args, "--connect", "tcp/127.0.0.1:1"],
                          capture_output=True, text=True, timeout=WAIT)  # fmt: skip


def test_a_hand_over_of_other_vehicles_is_refused(tmp_path: Path) -> None:
    plan = tmp_path / "vehicle-1.starts"
    write_private(plan, vehicle_starts(load_scenario(PAPER, (), ()), [1]))
    done = _refused("--id", "2", "--plan", str(plan))
    assert done.returncode == 2
    assert done.stderr == f"cpf: error: {plan}: the vehicles of --id [2] are not those it starts, got [1]\n"


def test_a_hand_over_others_could_write_or_that_is_none_is_refused(tmp_path: Path) -> None:
    plan = tmp_path / "vehicle-1.starts"
    write_private(plan, vehicle_starts(load_scenario(PAPER, (), ()), [1]))
    plan.chmod(0o620)
    done = _refused("--id", "1", "--plan", str(plan))
    assert (done.returncode, done.stderr) == (2, f"cpf: error: {plan}: not a private file of this user's "
                                                 "(mode -rw--w----)\n")  # fmt: skip
    other = tmp_path / "other.starts"
    other.write_text("not a pickle")
    other.chmod(0o600)
    done = _refused("--id", "1", "--plan", str(other))
    assert done.returncode == 2
    assert done.stderr.startswith(f"cpf: error: {other}: not vehicle starts written by cpf run (")
    assert done.stderr.count("\n") == 1

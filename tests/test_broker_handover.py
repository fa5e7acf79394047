"""The broker the supervisor starts is handed what it serves (comms.broker.broker_start) instead of loading the
scenario: it never imports pydantic, starts on half the CPU, and yet answers the hello with the supervisor's digests and
runs the same channel (a whole run is bit-identical: tests/test_bit_identical.py); a file that is not such a hand-over,
or a vehicle's, is refused with a one-line error."""

from __future__ import annotations

import os
import subprocess
import threading
from pathlib import Path

import zenoh

from comms.bus.bus import free_port, open_session
from comms.bus.handover import write_private
from comms.records.messages import COMMS_ALIVE, STOP_KEY, SUPERVISOR_ALIVE, Hello, encode
from supervisor.config.broker_start import broker_start
from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_digest import digest, section_digests
from supervisor.config.vehicle_start import vehicle_starts
from supervisor.engine.launch import BusOptions, Launch
from supervisor.engine.startup import ask_hello
from tests.conftest import CONFIGS
from tests.procs import CPF

PAPER = CONFIGS / "paper.toml"
WAIT = 60.0  # s: generous bounds, never reached when things work


def test_a_spawned_broker_loads_no_pydantic_and_proves_the_supervisors_scenario(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    scenario = load_scenario(PAPER, (), ())
    launch = Launch(PAPER, endpoint, BusOptions(), 7, tmp_path)
    handed = launch.handover("comms broker", broker_start(scenario, 7))
    assert (tmp_path / "comms-broker.start").stat().st_mode & 0o777 == 0o600
    argv = launch.argv("comms", "--start-step", "0", *handed)
    expected = section_digests(scenario, 7)
    with open_session("router", listen=[endpoint]) as session:
        token = session.liveliness().declare_token(SUPERVISOR_ALIVE)
        came = threading.Event()

        def on_token(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.PUT:
                came.set()

        watcher = session.liveliness().declare_subscriber(COMMS_ALIVE, on_token)
        env = {k: v for k, v in os.environ.items() if not k.startswith("CPF_")}
        child = subprocess.Popen(argv, env=env, stdin=subprocess.DEVNULL)
        try:
            assert came.wait(WAIT)
            assert ask_hello(session, COMMS_ALIVE, timeout=10.0) == Hello("comms broker", digest(expected), expected)
            maps = Path(f"/proc/{child.pid}/maps").read_text()
            assert "zenoh" in maps  # what it should have: the test reads the right process
            assert "pydantic_core" not in maps
        finally:
            session.put(STOP_KEY, encode({"t": 0.0, "reason": "end of run"}))
            code = child.wait(WAIT)
            watcher.undeclare()
            token.undeclare()
    assert code == 0
    # started by hand here (no lifeline): a --plan a user hands it is the user's, kept (one the supervisor hands a
    # process it launches is consumed: tests/test_orphans.py, nothing of a killed run left)
    assert (tmp_path / "comms-broker.start").exists()


def _refused(plan: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([CPF, "comms", str(PAPER), "--plan", str(plan), "--connect", "tcp/127.0.0.1:1"],
                          capture_output=True, text=True, timeout=WAIT)  # fmt: skip


def test_a_vehicles_hand_over_or_none_is_refused_by_the_broker(tmp_path: Path) -> None:
    plan = tmp_path / "vehicle-1.start"
    write_private(plan, vehicle_starts(load_scenario(PAPER, (), ()), [1]))
    done = _refused(plan)
    assert (done.returncode, done.stderr) == (2, f"cpf: error: {plan}: not a broker start written by cpf run "
                                                 "(a tuple)\n")  # fmt: skip
    other = tmp_path / "other.start"
    other.write_text("not a pickle")
    other.chmod(0o600)
    done = _refused(other)
    assert done.returncode == 2
    assert done.stderr.startswith(f"cpf: error: {other}: not a broker start written by cpf run (")
    assert done.stderr.count("\n") == 1


def test_a_broker_hand_over_others_could_write_is_refused(tmp_path: Path) -> None:
    plan = tmp_path / "comms-broker.start"
    write_private(plan, broker_start(load_scenario(PAPER, (), ()), 0))
    plan.chmod(0o660)
    done = _refused(plan)
    assert (done.returncode, done.stderr) == (2, f"cpf: error: {plan}: not a private file of this user's "
                                                 "(mode -rw-rw----)\n")  # fmt: skip

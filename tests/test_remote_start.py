"""A distributed run's start, as a user meets it: vehicles started by hand (here on one machine, by the test).

    vehicle 2 ---- vehicle 1 ---- vehicle 3        (paper graph; --remote: the test starts them, not cpf run)

The supervisor names the processes it waits for, gives up after --start-timeout leaving a log `cpf info` reads,
refuses a vehicle that runs another scenario (naming it and the section that differs), and a vehicle started by
hand ends quietly when the run ends.
"""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from comms.bus.bus import free_port
from tests.conftest import shortened
from tests.procs import CPF, cpf, processes_with, wait_for_file

pytestmark = pytest.mark.e2e
WAIT = 60  # s: generous bounds on a process's end, never reached when things work


@contextmanager
def started(args: list[str], cwd: Path) -> Iterator[subprocess.Popen[str]]:
    """cpf in its own session, stopped with its process group whatever happens."""
    proc = subprocess.Popen(
        [CPF, *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        yield proc
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=WAIT)


@pytest.fixture
def scenario(tmp_path: Path, paper_text: str) -> Path:
    path = tmp_path / "short.toml"
    path.write_text(shortened(paper_text, 2.0))
    return path


def supervisor(scenario: Path, endpoint: str, *extra: str) -> list[str]:
    """cpf run for vehicles started by hand: their credential files in creds/ (cpf vehicle --credentials)."""
    return ["run", str(scenario), "--listen", endpoint, "--out", "run.mcap", "--quiet", "--credentials-dir", "creds",
            *extra]  # fmt: skip


def by_hand(scenario: Path, vid: int, endpoint: str, *extra: str) -> list[str]:
    """cpf vehicle as a user starts it, once cpf run has written its credential file."""
    credentials = scenario.parent / "creds" / f"vehicle-{vid}.json"
    wait_for_file(credentials)
    return ["vehicle", str(scenario), "--id", str(vid), "--connect", endpoint, "--credentials", str(credentials),
            *extra]  # fmt: skip


def test_missing_vehicles_are_named_while_waiting_and_the_log_is_a_valid_empty_run(scenario: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started(supervisor(scenario, endpoint, "--remote", "2,3", "--start-timeout", "6"), scenario.parent) as run:
        _, err = run.communicate(timeout=WAIT)
    assert run.returncode == 1, err
    lines = err.splitlines()
    assert "cpf run: waiting for vehicles 2, 3 (started by hand) to come alive (5 s of 6 s)" in lines, err
    assert lines[-1] == "cpf: error: timed out after 6 s waiting for vehicles 2, 3 (started by hand) to come alive"
    info = cpf("info", "run.mcap", cwd=scenario.parent)
    assert info.returncode == 0, info.stderr
    assert "scenario   paper (" in info.stdout and "not a cpf run" not in info.stdout, info.stdout
    assert "cpf/run/meta" in info.stdout and "cpf/clock/tick" not in info.stdout
    assert processes_with(str(scenario)) == []


def test_a_vehicle_started_with_other_settings_is_refused_naming_it_and_the_difference(scenario: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        started(supervisor(scenario, endpoint, "--remote", "2", "--start-timeout", "30"), scenario.parent) as run,
        started(by_hand(scenario, 2, endpoint, "--set", "coordination.k=0.5"), scenario.parent) as vehicle,
    ):
        _, err = run.communicate(timeout=WAIT)
        _, vehicle_err = vehicle.communicate(timeout=WAIT)
    assert run.returncode == 2, err
    last = err.splitlines()[-1]
    assert last.startswith("cpf: error: vehicle 2 runs another scenario than the supervisor (differs in coordination)")
    assert vehicle.returncode == 2  # refused: bad input, so that a script starting it can tell (it was 0)
    assert "stopped by the supervisor: vehicle 2 runs another scenario" in vehicle_err, vehicle_err
    info = cpf("info", "run.mcap", cwd=scenario.parent)
    assert info.returncode == 0 and "scenario   paper (" in info.stdout, info.stdout + info.stderr
    assert processes_with(str(scenario)) == []


@pytest.mark.parametrize("attempt", range(3))  # the stop message and the supervisor's leaving used to race
def test_vehicles_started_by_hand_end_quietly_with_the_run(scenario: Path, attempt: int) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        started(supervisor(scenario, endpoint, "--remote", "1,2,3"), scenario.parent) as run,
        started(by_hand(scenario, 1, endpoint), scenario.parent) as one,
        started(by_hand(scenario, 2, endpoint), scenario.parent) as two,
        started(by_hand(scenario, 3, endpoint), scenario.parent) as three,
    ):
        _, err = run.communicate(timeout=WAIT)
        ends = [v.communicate(timeout=WAIT) for v in (one, two, three)]
    assert run.returncode == 0, err
    for vehicle, (_, vehicle_err) in zip((one, two, three), ends, strict=True):
        assert vehicle.returncode == 0
        assert vehicle_err == "", vehicle_err  # in particular not "the supervisor is gone"
    assert processes_with(str(scenario)) == []

"""The fork server (supervisor.cli.fork_server, supervisor.forked): a forked `cpf` child is what a spawned one was (its
own session, its command line, its descriptors at their numbers, its lifeline, its exit code and last words), a run
forked records what a run spawned records, and a fork server killed at any time leaves nothing behind.

    cpf run --(spawn)--> fork server (--run <scenario>) --(fork, per request on a Unix socket)--> broker, vehicles
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from comms.bus.bus import free_port
from supervisor import processes
from supervisor.forked import LOST, cli_args
from supervisor.processes import ProcessGroup
from tests.conftest import shortened
from tests.procs import (
    cpf,
    processes_with,
    start_cpf,
    wait_for_no_processes,
    wait_for_progress,
    wait_until,
    watching_lifeline,
)
from tests.test_faults_e2e import read_run

pytestmark = pytest.mark.e2e
GONE_WITHIN = 2.0  # s (issue 14)


def test_only_this_interpreters_cpf_command_lines_are_forked() -> None:
    assert cli_args([sys.executable, "-P", "-m", "supervisor.cli", "vehicle", "x.toml"]) == ["vehicle", "x.toml"]
    assert cli_args([sys.executable, "-m", "supervisor.cli", "comms"]) == ["comms"]
    assert cli_args(["/usr/bin/python3.9", "-m", "supervisor.cli", "comms"]) is None  # another interpreter
    assert cli_args([sys.executable, "-m", "supervisor.record.live_relay"]) is None  # another module
    assert cli_args([sys.executable, "-X", "dev", "-m", "supervisor.cli", "comms"]) is None  # other flags
    assert cli_args([sys.executable, "-c", "print(1)"]) is None


def _server(group: ProcessGroup) -> int:
    assert group.fork_server is not None
    return group.fork_server


def _parent(pid: int) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(next(line.split()[1] for line in status.splitlines() if line.startswith("PPid:")))


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _stuck_vehicle(scenario: Path, text: str) -> tuple[Path, list[str]]:
    """The scenario written, and the command line of its vehicle 1 joining a router that never comes (it waits in
    Zenoh's connect until its lifeline ends it)."""
    scenario.write_text(text)
    nowhere = f"tcp/127.0.0.1:{free_port()}"
    return scenario, [
        sys.executable,
        "-P",
        "-m",
        "supervisor.cli",
        "vehicle",
        str(scenario),
        "--id",
        "1",
        "--connect",
        nowhere,
    ]


def test_a_forked_child_has_its_own_session_command_line_and_lifeline(tmp_path: Path, paper_text: str) -> None:
    """A vehicle joining a router that never comes: it waits in Zenoh's connect, watching its lifeline, until the
    group stops it (the lifeline cut: it ends by itself)."""
    scenario, argv = _stuck_vehicle(tmp_path / "forked.toml", paper_text)
    with ProcessGroup(fork=str(scenario)) as group:
        child = group.spawn("vehicle 1", argv)
        pid = child.process.pid
        server = _server(group)
        assert f"--run {scenario}" in _cmdline(server)
        assert wait_until(lambda: watching_lifeline(pid)), "the forked vehicle never watched its lifeline"
        assert wait_until(lambda: _cmdline(pid).split() == argv)  # ps sees its command, not the fork server's
        assert os.getsid(pid) == pid  # its own session: a Ctrl-C at the terminal does not reach it
        assert _parent(pid) == server
        assert child.process.poll() is None
        group.stop()
        assert child.process.poll() is not None
    assert processes_with(str(scenario)) == []


def test_a_forked_child_gets_its_descriptors_at_their_numbers_and_says_why_it_ended(paper_text: str) -> None:
    """`cpf validate /proc/self/fd/N`: N is a memory file only the child was handed (as a credential is); then a
    scenario that is not one: its exit code and last words, as a spawned child's."""
    good = os.memfd_create("good.toml")
    os.write(good, paper_text.encode())
    bad = os.memfd_create("bad.toml")
    os.write(bad, b"[scenario]\nduration = -1\n")
    validate = [sys.executable, "-P", "-m", "supervisor.cli", "validate"]
    fds = {"good": (good,), "bad": (bad,)}
    try:
        with ProcessGroup(fds_of=lambda name: fds[name], fork="validate") as group:
            ok = group.spawn("good", [*validate, f"/proc/self/fd/{good}"])
            refused = group.spawn("bad", [*validate, f"/proc/self/fd/{bad}"])
            assert ok.process.wait(timeout=60) == 0, ok.last_words()
            assert refused.process.wait(timeout=60) == 2
            assert refused.how_it_ended() == f"exit code 2: {refused.last_words()}"
            assert refused.last_words().startswith("cpf: error:")
            assert _server(group) not in (ok.process.pid, refused.process.pid)
    finally:
        os.close(good)
        os.close(bad)


def test_a_run_forked_records_what_a_run_spawned_records(tmp_path: Path, paper_text: str) -> None:
    scenario = tmp_path / "paper.toml"
    scenario.write_text(shortened(paper_text, 30.0))
    runs = {}
    for start in ("fork", "spawn"):
        done = cpf("run", str(scenario), "--start", start, "--out", f"{start}.mcap", "--quiet", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        assert "spawning" not in done.stderr  # forked, not fallen back to spawning (supervisor.processes says so)
        runs[start] = read_run(tmp_path / f"{start}.mcap")
    assert runs["fork"] == runs["spawn"]
    assert len(runs["fork"][0]) == 3 * 300


def test_sigkill_of_the_fork_server_mid_run_leaves_the_run_going_and_nothing_behind(
    tmp_path: Path, paper_text: str
) -> None:
    """Once its children serve they watch the supervisor's lifeline, not the fork server: the run goes on."""
    scenario = tmp_path / "server_killed.toml"
    scenario.write_text(shortened(paper_text, 200.0))
    run = start_cpf(["run", str(scenario), "--out", "run.mcap"], tmp_path)
    try:
        wait_for_progress(run, 10.0)
        (server,) = [p for p, c in processes_with(str(scenario)) if "supervisor.cli.fork_server" in c]
        os.kill(server, signal.SIGKILL)
        _, err = run.communicate(timeout=300)
    finally:
        run.kill()
    assert run.returncode == 0, err
    assert wait_for_no_processes(str(scenario), timeout=GONE_WITHIN) == []


def test_sigkill_of_the_fork_server_during_start_up_leaves_nothing_behind(tmp_path: Path, paper_text: str) -> None:
    """Killed as soon as it has forked a child: the children not yet watching their lifeline go with it (their
    parent-death signal), cpf says which process it lost and exits, and nothing of the run remains."""
    scenario = tmp_path / "server_killed_early.toml"
    scenario.write_text(shortened(paper_text, 200.0))
    run = start_cpf(["run", str(scenario), "--out", "run.mcap"], tmp_path)
    try:
        forked = lambda: [p for p, c in processes_with(str(scenario)) if "supervisor.cli" in c and p != run.pid]  # noqa: E731
        assert wait_until(lambda: bool(forked())), "no child forked"
        (server,) = [p for p, c in processes_with(str(scenario)) if "supervisor.cli.fork_server" in c]
        os.kill(server, signal.SIGKILL)
        _, err = run.communicate(timeout=300)
    finally:
        run.kill()
    assert run.returncode in (0, 1), err  # a run that lost a starting child stops with an error, not a traceback
    assert "Traceback" not in err
    assert wait_for_no_processes(str(scenario), timeout=GONE_WITHIN) == []


def test_a_childs_end_is_seen_though_its_fork_server_is_gone(tmp_path: Path, paper_text: str) -> None:
    """Its pidfd says it ended; its exit status went with the server (LOST)."""
    scenario, argv = _stuck_vehicle(tmp_path / "orphaned.toml", paper_text)
    with ProcessGroup(fork=str(scenario)) as group:
        child = group.spawn("vehicle 1", argv)
        assert wait_until(lambda: watching_lifeline(child.process.pid))
        os.kill(_server(group), signal.SIGKILL)
        assert child.process.poll() is None  # it serves on
        os.killpg(child.process.pid, signal.SIGKILL)  # (SIGTERM waits for Zenoh's connect to give up: 30 s)
        assert child.process.wait(timeout=30) == LOST
        later = group.spawn("vehicle 1", argv)  # no server to fork it: spawned
        assert isinstance(later.process, subprocess.Popen)
        assert wait_until(lambda: watching_lifeline(later.process.pid))
    assert processes_with(str(scenario)) == []


def test_a_fork_server_that_cannot_start_leaves_the_children_spawned(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """No time to say it is ready: the server is stopped, said so, and the child spawned as before."""
    monkeypatch.setattr(processes, "FORK_SERVER_TIMEOUT", 0.0)
    with ProcessGroup(fork="label") as group:
        child = group.spawn("validate", [sys.executable, "-P", "-m", "supervisor.cli", "validate", "nowhere.toml"])
        assert isinstance(child.process, subprocess.Popen)
        assert child.process.wait(timeout=60) == 2
        assert group.fork_server is None
    assert "no fork server (the fork server did not start): spawning every process" in caplog.text
    assert processes_with("supervisor.cli.fork_server --run label") == []

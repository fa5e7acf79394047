"""Smoke run of benchmarks/bench_critical_path.py (part of `make bench`): a short Zenoh run sampled from /proc gives
every process's CPU and its threads' context switches, and the summary sets the step against the bus floor (no
timing is asserted here)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.bench_critical_path import _children, _name, run_once, summary
from tests.conftest import CONFIGS, ROOT, shortened
from tests.procs import wait_until

pytestmark = pytest.mark.e2e
PROCESSES = {"supervisor", "fork server", "broker", "vehicle 1", "vehicle 2", "vehicle 3"}


def test_a_sampled_run_names_every_process_with_its_cpu_and_switches(tmp_path: Path) -> None:
    scenario = tmp_path / "paper.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 3.0))
    run = run_once(ROOT, str(scenario), 3)
    assert set(run["cpu_s"]) == PROCESSES and set(run["switches"]) == PROCESSES
    switches = dict(run["switches"])
    assert switches.pop("fork server")[2] == 1  # no thread of its own: a fork copies only the forking one
    assert all(voluntary > 0 and threads > 1 for voluntary, _, threads in switches.values())
    row = {"tree": "here", "steps": 30, "best": run, "ms_per_step": 2.0, "floor_ms_per_step": 1.0}
    assert "(lean bus floor 1.00 ms: 2.00x it; issue 26's target <= 1.5x)" in summary(row)


def test_only_cpfs_own_child_is_named_the_fork_server() -> None:
    """A child the fork server has just forked shows the server's command line until it sets its own title: sampled
    then, it was counted as the fork server (2 threads, in 1 of 3 fresh-clone runs). Only cpf's own child is."""
    argv = [sys.executable, "-c", "import sys; sys.stdin.read()", "-m", "supervisor.cli.fork_server", "--run", "x"]
    with subprocess.Popen(argv, stdin=subprocess.PIPE) as lookalike:
        try:  # (until it has exec'd, its command line is this process's)
            assert wait_until(lambda: b"fork_server" in Path(f"/proc/{lookalike.pid}/cmdline").read_bytes())
            tree = _children()
            assert _name(lookalike.pid, os.getpid(), tree) == "fork server"  # our child: the fork server of "our" run
            assert _name(lookalike.pid, os.getppid(), tree) is None  # a grandchild of that cpf: a child not yet titled
        finally:
            lookalike.kill()

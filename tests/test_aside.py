"""supervisor.analysis.aside: a call made in a forked child, its result or its exception brought back, nothing of the
child left behind; cpf report reads its log that way (the report is the same as read here)."""

from __future__ import annotations

import json
import os
import signal
import threading
from pathlib import Path
from typing import Any

import pytest

from supervisor.analysis import aside as aside_module
from supervisor.analysis.aside import aside
from supervisor.analysis.rundata import read_for_report
from supervisor.cli import main
from supervisor.errors import CpfError, LogError
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf


def child_pid() -> int:
    return os.getpid()


def fails() -> None:
    raise LogError("r.mcap: not an MCAP file")


def test_the_call_runs_in_a_child_and_its_result_comes_back() -> None:
    with aside(child_pid) as pending:
        assert pending.pid is not None
        assert pending.result() != os.getpid()
    with aside(sorted, [3, 1, 2]) as pending:
        assert pending.result() == [1, 2, 3] and pending.result() == [1, 2, 3]  # asked twice: the same


def test_the_childs_exception_is_raised_here() -> None:
    with aside(fails) as pending, pytest.raises(LogError, match=r"r\.mcap: not an MCAP file"):
        pending.result()


def test_a_child_that_dies_is_an_error_not_a_hang() -> None:
    with aside(signal.pause) as pending:
        assert pending.pid is not None
        os.kill(pending.pid, signal.SIGKILL)
        with pytest.raises(CpfError, match=r"ended with no result \(killed by signal 9\)"):  # one line from cpf
            pending.result()  # (a RuntimeError was a traceback)


def test_leaving_the_block_early_leaves_no_child() -> None:
    with aside(signal.pause) as pending:
        pid = pending.pid
    assert pid is not None and pending.pid is None
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, os.WNOHANG)  # reaped, not a zombie left to the parent


def test_with_another_thread_alive_the_call_is_made_here() -> None:
    stop = threading.Event()
    helper = threading.Thread(target=stop.wait)
    helper.start()
    try:
        with aside(child_pid) as pending:
            assert pending.pid is None and pending.result() == os.getpid()
    finally:
        stop.set()
        helper.join()


def test_cpf_report_reads_aside_what_it_reads_here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 30.0))
    assert (
        cpf("run", str(scenario), "--engine", "inprocess", "--out", "r.mcap", "--quiet", cwd=tmp_path).returncode == 0
    )
    calls = []
    real = aside_module.aside

    def spy(call: Any, *args: Any) -> Any:
        calls.append((call, args))
        return real(call, *args)

    monkeypatch.setattr(aside_module, "aside", spy)
    assert main(["report", str(tmp_path / "r.mcap"), "--out", str(tmp_path / "aside")]) == 0
    assert calls == [(read_for_report, (tmp_path / "r.mcap",))]  # the log read aside, by the report's own reader
    here = tmp_path / "here"
    from supervisor.analysis.report import write_report

    write_report(tmp_path / "r.mcap", here, read_for_report(tmp_path / "r.mcap"))
    assert json.loads((tmp_path / "aside" / "metrics.json").read_text()) == json.loads(
        (here / "metrics.json").read_text()
    )
    assert sorted(p.name for p in (tmp_path / "aside").iterdir()) == sorted(p.name for p in here.iterdir())
    assert main(["report", str(tmp_path / "nope.mcap")]) == 2  # refused before anything is forked


def test_the_child_is_forked_with_ctrl_c_held_until_it_ignores_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """A Ctrl-C just after the fork ran cpf's handler in the child, before the child ignored SIGINT: a traceback
    from threading's after-fork hook (seen once, in the fresh clone's Ctrl-C report test)."""
    masks = []
    real_fork = os.fork

    def fork() -> int:
        masks.append(signal.pthread_sigmask(signal.SIG_BLOCK, []))  # the signals blocked as the child is made
        return real_fork()

    monkeypatch.setattr(aside_module.os, "fork", fork)
    with aside(signal.getsignal, signal.SIGINT) as pending:
        assert pending.result() == signal.SIG_IGN
    assert len(masks) == 1 and {signal.SIGINT, signal.SIGTERM} <= masks[0]
    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])  # and here, delivered again

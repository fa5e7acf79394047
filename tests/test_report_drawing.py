"""A report read in one pass and drawn on every core (supervisor.record.logfile.read_checked,
supervisor.analysis.drawing): the same messages, the same PNG bytes, nothing left behind when cpf is killed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from mcap.opcode import Opcode

from comms.records.messages import vehicle_of_key
from supervisor.analysis.drawing import MIN_PARALLEL, draw, workers
from supervisor.analysis.report import figure_builders, load_run
from supervisor.record import logfile
from tests.procs import CPF, wait_until
from tests.test_report import fault_event, write_run


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("drawing") / "run.mcap"
    return write_run(path, [fault_event(60.0, "start"), fault_event(90.0, "end")], [])


def states(topic: str) -> bool:
    owned = vehicle_of_key(topic)
    return owned is not None and owned[1] == "state"


@pytest.mark.parametrize("wanted", [lambda topic: True, states, lambda topic: False], ids=["all", "states", "none"])
def test_one_checked_pass_reads_what_the_indexed_reader_reads_in_the_same_order(log: Path, wanted) -> None:
    """Log-time order, equal times in the order written (the synthetic run writes many messages per instant)."""
    assert logfile.read_checked(log, wanted) == list(logfile.messages(log, wanted))


def test_the_checked_pass_refuses_damage_in_a_chunk_it_reads_no_message_of(log: Path, tmp_path: Path) -> None:
    with log.open("rb") as stream:
        chunk = next(offset for offset, opcode, _ in logfile._top_records(stream) if opcode == Opcode.CHUNK)
    data = bytearray(log.read_bytes())
    data[chunk + 100 : chunk + 140] = bytes(40)
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    with pytest.raises(logfile.LogError, match="cut short or damaged"):
        logfile.read_checked(damaged, lambda topic: False)


def test_figures_are_drawn_here_with_another_thread_alive_or_few_of_them() -> None:
    assert workers(MIN_PARALLEL - 1) == 1
    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    try:
        assert workers(100) == 1  # forking with another thread alive could copy a lock it holds
    finally:
        release.set()
        other.join()


def test_figures_drawn_by_forked_workers_are_the_bytes_drawn_one_by_one(log: Path, tmp_path: Path) -> None:
    """In a fresh interpreter: this test process has other threads (the test runner's), where draw forks no one."""
    run = load_run(log)
    figures = [f for f in figure_builders(run) if f[0] in CHEAP]
    (tmp_path / "here").mkdir()
    draw(run, figures, tmp_path / "here", 1)
    script = (
        "import sys; from pathlib import Path; from supervisor.analysis import drawing, report\n"
        "run = report.load_run(Path(sys.argv[1]))\n"
        "figures = [f for f in report.figure_builders(run) if f[0] in sys.argv[3:]]\n"
        "Path(sys.argv[2]).mkdir(); drawing.draw(run, figures, Path(sys.argv[2]), 2)\n"
    )
    subprocess.run([sys.executable, "-c", script, str(log), str(tmp_path / "forked"), *CHEAP], check=True, timeout=120)
    for name, _ in figures:
        assert (tmp_path / "forked" / f"{name}.png").read_bytes() == (tmp_path / "here" / f"{name}.png").read_bytes()


def test_a_worker_that_dies_while_the_figures_are_handed_out_is_one_line(
    log: Path, tmp_path: Path, monkeypatch
) -> None:
    """The pool broken at a submit (a worker killed before the last figure was handed out), not only at a result."""
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    from supervisor.analysis import drawing
    from supervisor.errors import CpfError

    class Broken(ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            raise BrokenProcessPool("A child process terminated abruptly")

    monkeypatch.setattr(drawing, "ProcessPoolExecutor", Broken)
    run = load_run(log)
    with pytest.raises(CpfError, match="a process drawing the report's figures died"):
        draw(run, [f for f in figure_builders(run) if f[0] in CHEAP], tmp_path, 2)


CHEAP = ("fig4_path_following_errors", "gamma_dot", "comms_lambda2")  # the quickest to draw: one per worker and more


def group_members(group: int) -> list[int]:
    """Live processes (zombies excepted) of a process group."""
    members = []
    for entry in Path("/proc").iterdir():
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[2]) == group and fields[0] != "Z":
            members.append(int(entry.name))
    return members


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one core: cpf report draws in its own process")
@pytest.mark.parametrize("how", ["SIGKILL of cpf", "Ctrl-C", "SIGKILL of a worker"])
def test_a_report_stopped_while_its_workers_draw_leaves_no_worker(log: Path, tmp_path: Path, how: str) -> None:
    report = subprocess.Popen(
        [CPF, "report", str(log), "--out", str(tmp_path)],
        start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        drawing = 2 if how == "SIGKILL of a worker" else 1  # its draw workers (the log's reader aside is one child)
        assert wait_until(lambda: len(group_members(report.pid)) > drawing, timeout=60), "no worker was forked"
        if how == "Ctrl-C":
            os.killpg(report.pid, signal.SIGINT)  # a terminal sends it to the whole foreground group
        elif how == "SIGKILL of a worker":  # (the report waited for ever for the figure it was drawing)
            os.kill(next(pid for pid in group_members(report.pid) if pid != report.pid), signal.SIGKILL)
        else:
            os.kill(report.pid, signal.SIGKILL)
        _, err = report.communicate(timeout=10)
        assert wait_until(lambda: not group_members(report.pid), timeout=5), group_members(report.pid)
        if how == "Ctrl-C":
            assert report.returncode == 130 and "Traceback" not in err and len(err.splitlines()) == 1, err
        if how == "SIGKILL of a worker":
            assert report.returncode == 1 and "Traceback" not in err and len(err.splitlines()) == 1, err
    finally:
        if group_members(report.pid):
            os.killpg(report.pid, signal.SIGKILL)


def test_a_log_without_a_single_state_is_reported(log: Path, tmp_path: Path) -> None:
    """A run that stopped before any vehicle's first state (a remote vehicle that never came, a cpf killed at its
    start, then recovered) leaves such a log: cpf report ended in a ValueError (the coordination figure's scale from
    no errors); now it draws the figures, empty, and the metrics."""
    from supervisor.cli import main
    from supervisor.record.recorder import Recorder

    stateless = tmp_path / "stateless.mcap"
    with Recorder(stateless, scene=False) as rec:
        for message in logfile.messages(log, lambda topic: not topic.endswith("/state")):
            rec.write(message.topic, message.log_time / 1e9, message.message)
    assert main(["report", str(stateless), "--out", str(tmp_path / "report")]) == 0
    assert (tmp_path / "report/fig5_coordination_errors.png").stat().st_size > 10_000
    assert (tmp_path / "report/metrics.json").exists()


def test_a_run_stopped_early_has_its_phases_end_where_its_data_does(log: Path, tmp_path: Path) -> None:
    """A log cut at 2 s (as a run stopped by Ctrl-C, or a lost vehicle, leaves one): its last phase ended at the
    scenario's duration, the data at 2 s (a new user's study); it ends one step past the last state now. A whole
    run's phases end at its duration, as before."""
    from supervisor.analysis.metrics import run_metrics
    from supervisor.record.recorder import Recorder

    whole = run_metrics(load_run(log))
    cut = tmp_path / "cut.mcap"
    with Recorder(cut, scene=False) as rec:
        for message in logfile.messages(log, lambda topic: True):
            if message.log_time <= 2_000_000_000:
                rec.write(message.topic, message.log_time / 1e9, message.message)
    stopped = run_metrics(load_run(cut))
    assert whole["coordination"]["phases"][-1]["end"] == whole["run"]["duration"] > 2.5
    run = stopped["run"]
    end = stopped["coordination"]["phases"][-1]["end"]
    assert end == pytest.approx(run["t_last"] + run["step"]) and end < run["duration"]

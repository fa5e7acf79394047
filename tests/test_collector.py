"""The garbage collector at our pace (supervisor.collector) from its start in a `cpf` command's process (and
the vehicle and broker processes it starts, forked or spawned, which run through its main) and a sweep's worker; and
for the length of a run from Python, the caller's thresholds given back after it; paused while a log's scene is
written. (What the pace buys is measured by benchmarks.bench_collector.)"""

from __future__ import annotations

import contextlib
import gc
import subprocess
import sys
from collections.abc import Iterator

import pytest

import cpf
from supervisor import collector
from tests.procs import ROOT

PROBES = {
    "a cpf command": "from supervisor.cli import main\nmain(['presets'])",
    # what a forked child runs (fork_server._child, after the fork): main, through _run
    "a process forked from the fork server": "from supervisor.cli.fork_server import _run\n_run(['presets'])",
    "a sweep's worker": "import os\nfrom supervisor.tools.sweep import _worker_start\n_worker_start(os.getppid())",
}


@pytest.mark.parametrize("how", PROBES)
def test_a_process_of_ours_collects_at_our_pace(how: str) -> None:
    probe = f"import gc, sys\nbefore = gc.get_threshold()\n{PROBES[how]}\nprint(before, gc.get_threshold())"
    done = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, check=True)
    before, after = eval(done.stdout.strip().splitlines()[-1].replace(") (", "), ("))
    assert after[0] == collector.YOUNG != before[0]  # CPython's default (700 in 3.11)
    assert after[1:] == before[1:]  # the older generations' as CPython has them


def test_paced_gives_the_thresholds_back_even_when_the_block_raises() -> None:
    before = gc.get_threshold()
    gc.set_threshold(1234, 5, 6)
    try:
        with pytest.raises(RuntimeError), collector.paced():
            assert gc.get_threshold() == (collector.YOUNG, 5, 6)
            raise RuntimeError("the run failed")
        assert gc.get_threshold() == (1234, 5, 6)
    finally:
        gc.set_threshold(*before)


def test_runs_paced_at_once_in_threads_give_back_the_thresholds_of_before_the_first():
    """cpf.run in two threads: the second's start saw the first's pace; the thresholds must still come back (the
    review's reproduction left a notebook at 10,000)."""
    before = gc.get_threshold()
    gc.set_threshold(1234, 5, 6)
    try:
        with contextlib.ExitStack() as second:
            with collector.paced():
                second.enter_context(collector.paced())  # the second run starts while the first goes on
            assert gc.get_threshold() == (collector.YOUNG, 5, 6)  # the first ended, the second still paced
        assert gc.get_threshold() == (1234, 5, 6)
    finally:
        gc.set_threshold(*before)
    assert collector._PACE.count == 0


def test_a_collector_switched_off_stays_off():
    before = gc.get_threshold()
    gc.set_threshold(0, 10, 10)
    try:
        with collector.paced():
            assert gc.get_threshold()[0] == 0
    finally:
        gc.set_threshold(*before)


def test_a_run_from_python_is_paced_and_leaves_the_callers_collector_as_it_was(monkeypatch, tmp_path) -> None:
    import supervisor.cli.run

    seen = []

    def execute(args: object) -> tuple[None, None, None]:
        seen.append(gc.get_threshold())
        return None, None, None

    monkeypatch.setattr(supervisor.cli.run, "execute", execute)
    before = gc.get_threshold()
    gc.set_threshold(1234, 5, 6)
    try:
        cpf.run(ROOT / "configs" / "paper.toml", out=tmp_path / "run.mcap", progress=False)
        assert seen == [(collector.YOUNG, 5, 6)]
        assert gc.get_threshold() == (1234, 5, 6)
    finally:
        gc.set_threshold(*before)


def test_the_benchmarks_cpython_command_runs_at_cpythons_pace(monkeypatch, capsys):
    """benchmarks.bench_collector times a command at CPython's pace against ours: that command must not be ours."""
    import supervisor.cli
    from benchmarks.bench_collector import CPYTHON

    seen = []
    real = supervisor.cli.main

    def main(argv):
        code = real(argv)
        seen.append(gc.get_threshold()[0])
        return code

    before = gc.get_threshold()
    monkeypatch.setattr(collector, "YOUNG", collector.YOUNG)  # the command sets it: given back after the test
    monkeypatch.setattr(supervisor.cli, "main", main)
    monkeypatch.setattr(sys, "argv", ["-c", "presets"])
    try:
        with pytest.raises(SystemExit) as ended:
            exec(CPYTHON, {})
    finally:
        gc.set_threshold(*before)
    assert ended.value.code == 0 and seen == [700] and capsys.readouterr().out


def test_the_scene_is_written_with_the_collector_paused_and_it_runs_again_after(monkeypatch, tmp_path) -> None:
    """The log's Foxglove scene makes no cycles and the run's heap is large: no full scans of it meanwhile."""
    from supervisor.record.recorder import Recorder
    from supervisor.record.scene.scene import FleetScene, SceneMessage

    seen = []

    def messages(self: FleetScene) -> Iterator[SceneMessage]:
        seen.append(gc.isenabled())
        return iter(())

    monkeypatch.setattr(FleetScene, "messages", messages)
    assert gc.isenabled()
    with Recorder(tmp_path / "run.mcap"):
        assert gc.isenabled()
    assert seen == [False] and gc.isenabled()


def test_paused_blocks_in_threads_turn_the_collector_on_after_the_last_and_leave_it_off_if_it_was():
    assert gc.isenabled()
    with contextlib.ExitStack() as second:
        with pytest.raises(RuntimeError), collector.paused():
            second.enter_context(collector.paused())  # another scene begins while the first is written
            raise RuntimeError("the disk is full")
        assert not gc.isenabled()  # the first ended, the second still writes
    assert gc.isenabled() and collector._PAUSE.count == 0
    gc.disable()
    try:
        with collector.paused():
            pass
        assert not gc.isenabled()  # the caller's choice
    finally:
        gc.enable()


def test_a_large_fleets_steps_stay_below_the_young_threshold() -> None:
    """YOUNG is above what a step keeps alive (~10 tracked objects a vehicle, supervisor.collector): a ring of 1000
    AUVs collects young objects as its heap grows, not at every step (at 10,000: two young collections a step)."""
    import dataclasses

    from benchmarks.bench_targets import CASES, scenario_text
    from supervisor.config.scenario import parse_scenario
    from supervisor.engine.inprocess import InProcessRun
    from supervisor.record.recorder import Tally

    (case,) = [c for c in CASES if c.vehicles == 1000]
    scenario = parse_scenario(scenario_text(dataclasses.replace(case, duration=3.0)), "ring1000.toml")
    young: list[int] = []

    def counted(phase: str, info: dict[str, int]) -> None:
        if phase == "start" and info["generation"] == 0:
            young.append(1)

    with collector.paced():
        run = InProcessRun(scenario, Tally(), 1)
        gc.collect()
        gc.callbacks.append(counted)
        try:
            for k in range(30):
                run.step(k)
        finally:
            gc.callbacks.remove(counted)
    assert len(young) <= 30 / 5, len(young)  # at most one young collection in five steps

"""Vehicle hosts in real runs: a fleet served by one host process records what one process per vehicle and the
in-process engine record, record for record, through faults of every kind with a hosted vehicle killed and
restarted and another killed for good (its host-mates step on); a host's unscheduled death loses its vehicles, each
as the scenario says; neither a SIGKILLed host nor a SIGKILLed supervisor leaves a process behind.

    supervisor --control pipe--> host "vehicles 1,2,3" (vehicle 1 | vehicle 2 | vehicle 3: a session each)
"""

from __future__ import annotations

import io
import os
import signal
from pathlib import Path

import pytest

from supervisor.config.scenario import parse_scenario
from supervisor.engine.cosim import BusOptions, run_zenoh
from supervisor.engine.inprocess import RunResult, run_inprocess
from supervisor.engine.progress import Progress
from supervisor.processes import ProcessGroup
from tests.conftest import CONFIGS, shortened
from tests.procs import processes_with, start_cpf, wait_for_no_processes, wait_for_progress, wait_until
from tests.test_faults_e2e import EVERY_KIND, assert_balanced, read_run, records

pytestmark = pytest.mark.e2e

DURATION = 60.0
OVERRIDES = ["comms.transmit.period=1.0", "scenario.on_vehicle_loss=continue", "faults.0.start=3", "faults.0.end=9"]
FAULTS = [*EVERY_KIND, "kind=vehicle_kill,vehicle=3,start=58.5"]  # vehicle 2 killed 41-44 s; 3 for good at 58.5 s


def run(tmp: Path, engine: str, per_process: int | None, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, list[str]]:
    """The periodic scenario with every fault kind; the names of the processes the supervisor started."""
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    path = tmp / "s.toml"
    path.write_text(text)
    scenario = parse_scenario(text, str(path), OVERRIDES, FAULTS)
    out = tmp / f"{engine}-{per_process}.mcap"
    quiet = Progress(DURATION, io.StringIO(), enabled=False)
    if engine == "inprocess":
        run_inprocess(scenario, str(path), text, out, 0, quiet)
        return out, []
    names: list[str] = []
    spawn = ProcessGroup.spawn

    def named(self: ProcessGroup, name: str, argv: list[str], control_env: str | None = None) -> object:
        names.append(name)
        return spawn(self, name, argv, control_env)

    monkeypatch.setattr(ProcessGroup, "spawn", named)
    bus = BusOptions(overrides=tuple(OVERRIDES), faults=tuple(FAULTS))
    bus.per_process = per_process
    result: RunResult = run_zenoh(scenario, path, text, out, 0, "lockstep", 1.0, bus, quiet)
    monkeypatch.undo()
    assert result.series is not None
    assert processes_with(str(path)) == []
    return out, names


def test_a_hosted_fleet_records_what_a_process_per_vehicle_and_the_in_process_engine_record(tmp_path, monkeypatch):
    hosted, host_names = run(tmp_path, "zenoh", 3, monkeypatch)
    alone, alone_names = run(tmp_path, "zenoh", 1, monkeypatch)
    inprocess, _ = run(tmp_path, "inprocess", None, monkeypatch)
    expected = records(inprocess)
    assert records(hosted) == expected
    assert records(alone) == expected
    # One host served the fleet; vehicle 2's restart is a process of its own; the broker's restart, as ever.
    assert host_names == ["comms broker", "vehicles 1,2,3", "vehicle 2", "comms broker"]
    assert alone_names == ["comms broker", "vehicle 1", "vehicle 2", "vehicle 3", "vehicle 2", "comms broker"]
    states, links, faults = read_run(hosted)
    assert len(faults) == 2 + 2 * len(EVERY_KIND) + 1  # the scenario's speed cap, every kind, the last kill
    assert_balanced(links)
    steps = round(DURATION / 0.1)
    # Its host-mates stepped on while vehicle 2 was down and after vehicle 3 was killed for good.
    assert {k for v, k in states if v == 1} == set(range(steps))
    assert {k for v, k in states if v == 2} == set(range(steps)) - set(range(410, 440))
    assert {k for v, k in states if v == 3} == set(range(585))


def _host_pid(marker: str, ids: str) -> int:
    found = processes_with(marker)
    pids = [p for p, cmd in found if "supervisor.cli vehicle" in cmd and ids in cmd and "lifeline" not in cmd]
    assert len(pids) == 1, found
    return pids[0]


@pytest.mark.parametrize("on_loss", ["abort", "continue"])
def test_the_sigkill_of_a_host_loses_its_vehicles_as_the_scenario_says_and_leaves_no_process(
    tmp_path, paper_text, on_loss
):
    scenario = tmp_path / "host.toml"
    scenario.write_text(shortened(paper_text, 20000.0))  # cannot end on its own
    args = ["run", str(scenario), "--vehicles-per-process", "2", "--out", "run.mcap", "--set"]
    run = start_cpf([*args, f"scenario.on_vehicle_loss={on_loss}"], tmp_path)
    try:
        wait_for_progress(run)
        host = _host_pid(str(scenario), "--id 1 --id 2")  # vehicle 3 is a process of its own
        os.kill(host, signal.SIGKILL)
        if on_loss == "abort":
            _, err = run.communicate(timeout=60)
            assert run.returncode == 1, err
            line = err.splitlines()[-1]  # whichever of its vehicles' tokens went first
            assert line.startswith(("cpf: error: vehicle 1 stopped", "cpf: error: vehicle 2 stopped")), err
            assert line.endswith("(killed by SIGKILL)"), err
        else:
            assert run.stderr is not None
            lost: list[str] = []
            for line in run.stderr:
                lost += [line] if " lost at t = " in line else []
                if len(lost) == 2:
                    break
            assert sorted(line.split()[3] for line in lost) == ["1", "2"], lost
            assert all("(killed by SIGKILL); going on without it" in line for line in lost), lost
            wait_for_progress(run, float(lost[-1].split("t = ")[1].split()[0]) + 1.0)  # vehicle 3 steps on
            assert _host_pid(str(scenario), "--id 3") > 0
            run.send_signal(signal.SIGTERM)
            run.communicate(timeout=60)
            assert run.returncode == 130
    finally:
        run.kill()
    assert wait_for_no_processes(str(scenario), timeout=5.0) == []


def test_the_sigkill_of_the_supervisor_leaves_no_host_after_2_s(tmp_path, paper_text):
    scenario = tmp_path / "orphans.toml"
    scenario.write_text(shortened(paper_text, 20000.0))
    run = start_cpf(["run", str(scenario), "--vehicles-per-process", "3", "--out", "killed.mcap"], tmp_path)
    try:
        wait_for_progress(run)
        assert wait_until(lambda: bool(_host_pid(str(scenario), "--id 1 --id 2 --id 3")))
        run.send_signal(signal.SIGKILL)
        run.communicate(timeout=10)
    finally:
        run.kill()
    assert wait_for_no_processes(str(scenario), timeout=2.0) == []

"""Vehicle hosts without a run: how many vehicles each process serves by default and how a fleet is split (pure),
that the supervisor says so when the default hosts, the host's orders, and the options that are refused.

    fleet <= 2 x cores: a process per vehicle      fleet > 2 x cores: a host per core, ceil(fleet / cores) each
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest

from benchmarks.bench_scaling import ring_scenario
from comms.bus.bus import Extras
from supervisor.cli import main
from supervisor.config.scenario import parse_scenario
from supervisor.engine import supervisor as supervisor_module
from supervisor.engine.bus_access import RunAccess
from supervisor.engine.hosting import default_per_process, groups, host_name, hosted_ids, hosts_chosen
from supervisor.engine.launch import BusOptions, Launch
from supervisor.engine.supervisor import Roster, Supervisor
from tests.conftest import CONFIGS
from vehicles.host import CONTROL_ENV, parse_order


@pytest.mark.parametrize(
    ("fleet", "cores", "expected"),
    [(3, 2, 1), (4, 2, 1), (5, 2, 3), (50, 2, 25), (100, 2, 50), (10, 8, 1), (17, 8, 3), (7, 1, 7), (1, 1, 1)],
)
def test_the_default_is_a_process_per_vehicle_up_to_twice_the_cores_then_a_host_per_core(fleet, cores, expected):
    assert default_per_process(fleet, cores) == expected
    if expected > 1:
        assert len(groups(list(range(fleet)), expected)) <= cores  # at most a host per core


@pytest.mark.parametrize(
    ("count", "per_process", "sizes"),
    [(50, 25, [25, 25]), (50, 20, [17, 17, 16]), (3, 1, [1, 1, 1]), (3, 5, [3]), (10, 4, [4, 3, 3]), (0, 3, [])],
)
def test_a_fleet_is_split_into_as_few_and_as_even_processes_as_the_bound_allows(count, per_process, sizes):
    ids = [7 + 2 * i for i in range(count)]  # ids need not be 1..N
    split = groups(ids, per_process)
    assert [len(g) for g in split] == sizes
    assert [v for g in split for v in g] == ids  # every vehicle once, in order
    assert all(len(g) <= per_process for g in split)


def test_a_hosts_name_gives_back_its_vehicles_and_no_other_name_does() -> None:
    assert host_name((4, 5, 16)) == "vehicles 4,5,16"
    assert hosted_ids(host_name((4, 5, 16))) == (4, 5, 16)
    assert hosted_ids("vehicle 4") is None and hosted_ids("comms broker") is None


def test_what_the_default_chose_is_said_in_one_line() -> None:
    line = hosts_chosen(50, 2, 25)
    assert line == (
        "50 vehicles on 2 cores: 2 vehicle hosts of up to 25 vehicles each (--vehicles-per-process 1: one process "
        "per vehicle)"
    )
    assert hosts_chosen(3, 1, 3).startswith("3 vehicles on 1 core: 1 vehicle host of up to 3")


def test_a_host_obeys_kill_orders_for_its_own_vehicles_only() -> None:
    mine = {4: None, 5: None}
    assert parse_order("kill 5\n", mine) == 5
    assert parse_order("kill 6\n", mine) is None  # not its vehicle
    assert [parse_order(line, mine) for line in ("kill", "kill x", "stop 4", "kill 4 5", "")] == [None] * 5


class _Procs:
    def __init__(self) -> None:
        self.spawned: list[tuple[str, list[str], str | None]] = []

    def spawn(self, name: str, argv: list[str], control_env: str | None = None) -> None:
        self.spawned.append((name, argv, control_env))


def _spawned(fleet: int, cores: int, per_process: int | None, monkeypatch: Any, tmp_path: Path) -> _Procs:
    """The processes a supervisor starts for a ring fleet on a machine of that many cores."""
    monkeypatch.setattr(supervisor_module, "cores", lambda: cores)
    run = Supervisor.__new__(Supervisor)  # only what spawn_vehicles needs: no bus
    bus = BusOptions()
    bus.per_process = per_process
    run.sc = parse_scenario(ring_scenario(fleet, 10.0))
    run.launch = Launch(tmp_path / "s.toml", "tcp/127.0.0.1:1", bus, 0, tmp_path)
    run.procs, run.roster, run.hosted = _Procs(), Roster(), {}  # type: ignore[assignment]
    run.spawn_vehicles()
    return run.procs  # type: ignore[return-value]


def test_the_supervisor_says_when_the_default_picks_hosts(monkeypatch, tmp_path, caplog) -> None:
    with caplog.at_level(logging.INFO, "cpf.engine"):
        procs = _spawned(10, 2, None, monkeypatch, tmp_path)
    assert [name for name, _, _ in procs.spawned] == ["vehicles 1,2,3,4,5", "vehicles 6,7,8,9,10"]
    assert all(control == CONTROL_ENV for _, _, control in procs.spawned)
    argv = procs.spawned[0][1]
    assert [argv[i + 1] for i, a in enumerate(argv) if a == "--id"] == ["1", "2", "3", "4", "5"]
    assert [r.getMessage() for r in caplog.records] == [hosts_chosen(10, 2, 5)]


@pytest.mark.parametrize(("fleet", "per_process", "names"), [(4, None, 4), (10, 1, 10), (10, 10, 1)])
def test_a_small_fleet_or_a_forced_choice_says_nothing(monkeypatch, tmp_path, caplog, fleet, per_process, names):
    with caplog.at_level(logging.INFO, "cpf.engine"):
        procs = _spawned(fleet, 2, per_process, monkeypatch, tmp_path)
    assert len(procs.spawned) == names
    assert caplog.records == []
    if per_process == 1 or per_process is None:
        assert [name for name, _, _ in procs.spawned] == [f"vehicle {v}" for v in range(1, fleet + 1)]


def test_a_host_gets_the_credential_of_each_of_its_vehicles_and_no_other() -> None:
    access = RunAccess(Extras(), fds={"vehicle 1": 11, "vehicle 2": 12, "vehicle 3": 13, "comms broker": 10})
    assert access.fds_of("vehicles 1,3") == (11, 13)
    assert access.env_of("vehicles 1,3") == {"CPF_CREDENTIALS": "/proc/self/fd/11:/proc/self/fd/13"}
    assert access.env_of("vehicle 2") == {"CPF_CREDENTIALS": "/proc/self/fd/12"}


# --- options ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["0", "-2", "1.5", "two", ""])
def test_a_bad_vehicles_per_process_is_refused_in_one_line(value, tmp_path, capsys) -> None:
    paper = tmp_path / "paper.toml"
    paper.write_text((CONFIGS / "paper.toml").read_text())
    with pytest.raises(SystemExit) as exit_info:
        main(["run", str(paper), "--vehicles-per-process", value, "--out", str(tmp_path / "x.mcap")])
    assert exit_info.value.code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1 and "--vehicles-per-process" in errors[0] and repr(value)[1:-1] in errors[0], errors
    assert not (tmp_path / "x.mcap").exists()


def test_vehicles_per_process_is_refused_with_the_in_process_engine(tmp_path, capsys) -> None:
    paper = tmp_path / "paper.toml"
    paper.write_text((CONFIGS / "paper.toml").read_text())
    out = tmp_path / "x.mcap"
    assert main(["run", str(paper), "--engine", "inprocess", "--vehicles-per-process", "2", "--out", str(out)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        f"cpf: error: {paper}: --vehicles-per-process: only the zenoh engine has processes to place (--engine "
        "inprocess runs one), got 2"
    ]
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--id", "1", "--id", "9"], "--id: no vehicle 9 in [[vehicles]]"),
        (["--id", "1", "--id", "2", "--gamma0", "3.0"], "--gamma0: name the vehicle (ID=GAMMA) when serving several"),
        (["--id", "1", "--id", "2", "--gamma0", "3=3.0"], "--gamma0: vehicle 3 is not one this process serves"),
        (["--id", "1", "--id", "2", "--resume", "state.json"], "--resume: restarts one vehicle, got --id 1, 2"),
    ],
)
def test_a_host_refuses_what_it_cannot_serve(args, expected, tmp_path, capsys) -> None:
    paper = tmp_path / "paper.toml"
    paper.write_text((CONFIGS / "paper.toml").read_text())
    assert main(["vehicle", str(paper), "--connect", "tcp/127.0.0.1:1", *args]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("cpf: error: ") and expected in lines[0], lines

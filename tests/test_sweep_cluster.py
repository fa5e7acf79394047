"""`cpf sweep --cluster`: the runs on a Dask cluster the test starts (distributed.LocalCluster on 127.0.0.1, free
ports, no dashboard). Workers in threads of this process (processes=False) run supervisor.tools.sweep_runs.run_one as
imported here, so a test can see (and hold up) every run the cluster does; `cpf sweep` is the client, run as a
user would."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import dask
import pytest
from distributed import LocalCluster
from distributed.diagnostics.plugin import SchedulerPlugin

import supervisor.tools.sweep_runs as sweep_module
from comms.bus.bus import free_port
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf, start_cpf
from tests.test_sweep_resim import read_rows

GRID = ["--param", "comms.loss=0,0.5", "--seeds", "2"]  # 2 values x 2 seeds


def local_cluster(workers: int = 1, processes: bool = False) -> LocalCluster:
    return LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=processes, protocol="tcp", host="127.0.0.1",
        scheduler_port=0, dashboard_address=":0",  # None means the default, 8787: two workers of the suite collided
    )  # fmt: skip


def write_scenario(where: Path) -> Path:
    path = where / "s.toml"
    path.write_text(shortened((CONFIGS / "paper.toml").read_text(), 10.0))
    return path


@pytest.fixture
def scenario(tmp_path: Path) -> Path:
    return write_scenario(tmp_path)


@pytest.fixture(scope="module")
def local_rows(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, str]]:
    """The grid's rows from a local sweep of the same scenario file (s.toml): one sweep for the module's tests."""
    where = tmp_path_factory.mktemp("local")
    done = cpf("sweep", str(write_scenario(where)), *GRID, "--jobs", "2", "--out", "local", cwd=where)
    assert done.returncode == 0, done.stderr
    return read_rows(where / "local/results.csv")


class Runs:
    """What the workers of this process run in place of run_one: records each run, and from hold_from on holds each
    run until release() (the real run_one does the work)."""

    def __init__(self, real: Callable[..., dict[str, Any]]) -> None:
        self.real = real
        self.hold_from: int | None = None
        self.ids: list[str] = []
        self.held = threading.Event()
        self._go = threading.Event()
        self._lock = threading.Lock()

    def __call__(self, name: str, data: bytes, spec: sweep_module.RunSpec, engine: str) -> dict[str, Any]:
        with self._lock:
            self.ids.append(spec.run_id)
            hold = self.hold_from is not None and len(self.ids) > self.hold_from
        if hold:
            self.held.set()
            self._go.wait()
        return self.real(name, data, spec, engine)

    def release(self) -> None:
        self._go.set()

    def reset(self) -> None:
        self.ids.clear()
        self.hold_from = None
        self.held.clear()
        self._go.clear()


RUNS = Runs(sweep_module.run_one)


def counted_run_one(name: str, data: bytes, spec: sweep_module.RunSpec, engine: str) -> dict[str, Any]:
    """run_one through RUNS. A module-level function: Dask pickles it by reference (to this module, which the
    workers of this process have imported), where an object with locks would not pickle at all."""
    return RUNS(name, data, spec, engine)


@pytest.fixture
def runs(monkeypatch: pytest.MonkeyPatch) -> Iterator[Runs]:
    RUNS.reset()
    monkeypatch.setattr(sweep_module, "run_one", counted_run_one)  # what cpf ships, by name, runs this here
    yield RUNS
    RUNS.release()  # a run still held would keep its worker thread, and the cluster's close, waiting


def test_a_cluster_sweep_gives_the_rows_of_a_local_sweep(tmp_path, scenario, local_rows, runs):
    with local_cluster() as cluster:
        done = cpf("sweep", str(scenario), *GRID, "--cluster", cluster.scheduler_address, "--out", "dask", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "sweep: 100%" in done.stderr and "4/4" in done.stderr  # progress as a local sweep's
    assert len(runs.ids) == 4 and len(set(runs.ids)) == 4  # every run on the cluster, once
    assert read_rows(tmp_path / "dask/results.csv") == local_rows  # the same rows, wall time aside
    assert (tmp_path / "dask/sweep_comms_loss.png").read_bytes().startswith(b"\x89PNG")


def test_a_cluster_sweep_brings_each_runs_log_back_when_asked(tmp_path, scenario, local_rows):
    """--logs on a cluster: each log comes back with its row (the workers share no directory with the client) and is
    written beside it, whole."""
    with local_cluster() as cluster:
        args = ["sweep", str(scenario), *GRID, "--cluster", cluster.scheduler_address, "--logs", "--out", "dask"]
        done = cpf(*args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    rows = read_rows(tmp_path / "dask/results.csv")
    assert [{k: v for k, v in r.items() if k != "log"} for r in rows] == local_rows
    runs = tmp_path / "dask/runs"
    assert sorted(r["log"] for r in rows) == sorted(f"runs/{p.name}" for p in runs.glob("*.mcap"))
    logs = sorted(runs.glob("*.mcap"))
    assert [p.stem for p in logs] == sorted(p.stem for p in runs.glob("*.json")) and len(logs) == 4
    for log in logs:
        info = cpf("info", str(log), cwd=tmp_path)
        assert info.returncode == 0 and "engine     inprocess" in info.stdout, info.stderr


def until_in(stream: IO[str], text: str) -> str:
    """What stream gives until text appears in it (or it ends): cpf's progress bar, read as it is drawn."""
    seen = ""
    while text not in seen and (char := stream.read(1)):
        seen += char
    return seen


def test_an_interrupted_cluster_sweep_resumes_with_only_the_missing_runs(tmp_path, scenario, local_rows, runs):
    args = ["sweep", str(scenario), *GRID, "--out", "dask"]
    runs.hold_from = 1  # the first run finishes, the second is held on the only worker thread
    with local_cluster() as cluster:
        sweeping = start_cpf([*args, "--cluster", cluster.scheduler_address], cwd=tmp_path)
        assert sweeping.stderr is not None
        shown = until_in(sweeping.stderr, "1/4")  # the client has the first run's row (kept before it is counted)
        assert "1/4" in shown, shown
        assert runs.held.wait(60), "the cluster never started a second run"
        sweeping.send_signal(signal.SIGINT)  # Ctrl-C, with a run under way on the cluster
        _, err = sweeping.communicate(timeout=60)  # and it stops
        runs.release()
    assert sweeping.returncode == 130, err
    assert err.strip().endswith("cpf: interrupted")
    kept = {p.name.removesuffix(".json") for p in (tmp_path / "dask/runs").iterdir() if p.name != "scenario.sha256"}
    assert len(kept) == 1 and kept <= set(runs.ids[:1])  # the finished run's row, whole (no .part left)

    runs.ids.clear()
    runs.hold_from = None
    with local_cluster() as cluster:
        again = cpf(*args, "--cluster", cluster.scheduler_address, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert "1/4" in again.stderr and "4/4" in again.stderr
    assert len(runs.ids) == 3 and kept.isdisjoint(runs.ids)  # only the missing runs ran again
    assert read_rows(tmp_path / "dask/results.csv") == local_rows


def test_an_unreachable_scheduler_is_a_one_line_error_and_nothing_is_written(tmp_path, scenario):
    address = f"tcp://127.0.0.1:{free_port()}"  # nothing listens there
    done = cpf(
        "sweep", str(scenario), *GRID, "--cluster", address, "--cluster-timeout", "1", "--out", "x", cwd=tmp_path
    )
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("cpf: error: --cluster: cannot reach")
    assert address in done.stderr
    assert not (tmp_path / "x").exists()


def test_a_cluster_without_workers_ends_the_sweep_with_an_error(tmp_path, scenario):
    with local_cluster(workers=0) as cluster:
        args = ["--cluster", cluster.scheduler_address, "--cluster-timeout", "1", "--out", "x"]
        done = cpf("sweep", str(scenario), *GRID, *args, cwd=tmp_path)
    assert done.returncode == 1
    assert "has had no worker for 1 s" in done.stderr and "run the sweep again to resume" in done.stderr


class KillFirstWorker(SchedulerPlugin):
    """SIGKILLs the worker process given the first run (its nanny starts a new one)."""

    def __init__(self, scheduler: Any) -> None:
        self.scheduler = scheduler
        self.killed: int | None = None

    def transition(self, key: Any, start: str, finish: str, *args: Any, **kwargs: Any) -> None:
        if finish == "processing" and self.killed is None:
            self.killed = self.scheduler.tasks[key].processing_on.pid
            os.kill(self.killed, signal.SIGKILL)


def test_a_run_whose_worker_dies_runs_again(tmp_path, scenario, local_rows):
    with local_cluster(processes=True) as cluster:
        killer = KillFirstWorker(cluster.scheduler)
        cluster.scheduler.add_plugin(killer)
        done = cpf("sweep", str(scenario), *GRID, "--cluster", cluster.scheduler_address, "--out", "dask", cwd=tmp_path)
    assert killer.killed is not None
    assert done.returncode == 0, done.stderr
    assert read_rows(tmp_path / "dask/results.csv") == local_rows


def test_a_run_whose_workers_keep_dying_is_reported(tmp_path, scenario):
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), local_cluster(processes=True) as cluster:
        killer = KillFirstWorker(cluster.scheduler)
        cluster.scheduler.add_plugin(killer)
        done = cpf("sweep", str(scenario), *GRID, "--cluster", cluster.scheduler_address, "--out", "dask", cwd=tmp_path)
    assert killer.killed is not None
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("cpf: error: sweep run ") and "failed" in last and "died" in last, done.stderr


def test_jobs_are_for_local_sweeps(tmp_path, scenario):
    done = cpf(
        "sweep", str(scenario), *GRID, "--cluster", "tcp://127.0.0.1:1", "--jobs", "3", "--out", "x", cwd=tmp_path
    )
    assert done.returncode == 2 and "--jobs" in done.stderr and not (tmp_path / "x").exists()

"""Runs stepped together (supervisor.engine.batch, a sweep's batches) give each run what it gives alone.

The batch steps every run's step k before any run's step k + 1 and its alike vehicles as lanes (vehicles.lanes, down
to groups of two here); each run's result must still be run_inprocess's without a log: series, message count, link
books, estimate ages. Runs of other lengths and steps share a batch; one that fails ends alone, the others go on.
"""

from __future__ import annotations

import csv
import io
from typing import Any

import numpy as np
import pytest

import vehicles.lanes
from supervisor.config.derived import steps_of
from supervisor.config.scenario import parse_scenario
from supervisor.engine.batch import BatchRun, run_batch
from supervisor.engine.inprocess import RunResult, run_inprocess
from supervisor.engine.progress import Progress
from supervisor.errors import ScenarioError, SimulationError
from supervisor.tools.sweep import BATCHES_PER_WORKER, _submitted, batches
from supervisor.tools.sweep_runs import RunSpec, run_many, run_one
from tests.conftest import CONFIGS, shortened
from tests.test_lanes import FAULTS


def lanes_counted(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Groups of 2 or more step as lanes (MIN_LANES lowered) and the vehicle steps taken so are counted: the list's
    one item, as the run goes."""
    monkeypatch.setattr(vehicles.lanes, "MIN_LANES", 2)
    together = [0]
    inner = vehicles.lanes._together

    def counted(jobs: Any) -> Any:
        together[0] += len(jobs)
        return inner(jobs)

    monkeypatch.setattr(vehicles.lanes, "_together", counted)
    return together


def _alone(run: BatchRun) -> RunResult:
    quiet = Progress(run.scenario.scenario.duration, io.StringIO(), enabled=False)
    return run_inprocess(run.scenario, run.scenario_file, run.scenario_toml, None, run.seed, quiet)


def _same(a: RunResult, b: RunResult) -> None:
    for name in ("t", "gamma", "gamma_dot", "path_error"):  # bit for bit: -0.0 is not 0.0
        x, y = np.asarray(getattr(a.series, name)), np.asarray(getattr(b.series, name))
        assert x.shape == y.shape and x.tobytes() == y.tobytes(), name
    assert (a.messages, a.link_counts, a.link_stats) == (b.messages, b.link_counts, b.link_stats)
    assert (a.stats_history, a.estimate_ages) == (b.stats_history, b.estimate_ages)


def _runs(settings: list[tuple[list[str], list[str], int]], duration: float) -> list[BatchRun]:
    text = shortened((CONFIGS / "paper.toml").read_text(), duration)
    return [BatchRun(parse_scenario(text, "paper.toml", o, f), "paper.toml", text, seed) for o, f, seed in settings]


def test_each_run_of_a_batch_is_the_run_alone(monkeypatch):
    monkeypatch.setattr(vehicles.lanes, "MIN_LANES", 2)
    runs = _runs(
        [
            ([], [], 0),
            (["comms.loss=0.3"], [], 1),
            (["comms.loss=0.3"], [], 2),
            ([], FAULTS, 3),  # every fault kind: kills and restarts change who steps
            (["scenario.duration=35.0"], [], 4),  # ends earlier
            (["scenario.step=0.05"], [], 5),  # steps of another length: a group of its own
        ],
        60.0,
    )
    together = run_batch(runs)
    for run, result in zip(runs, together, strict=True):
        assert isinstance(result, RunResult)
        _same(result, _alone(run))


def test_a_run_that_fails_in_a_batch_ends_alone_with_its_error(monkeypatch):
    monkeypatch.setattr(vehicles.lanes, "MIN_LANES", 2)
    runs = _runs([([], [], 0), (["scenario.step=1"], [], 1), (["comms.loss=0.2"], [], 2)], 20.0)
    together = run_batch(runs)
    with pytest.raises(SimulationError) as alone:
        _alone(runs[1])
    failed = together[1]
    assert isinstance(failed, SimulationError) and str(failed) == str(alone.value)
    assert "diverged at t = 1.0 s" in str(failed)
    for n in (0, 2):
        result = together[n]
        assert isinstance(result, RunResult)
        _same(result, _alone(runs[n]))


def test_a_sweep_batch_gives_each_run_its_own_row(monkeypatch):
    """sweep_runs.run_many (what `cpf sweep` sends a worker) against run_one per spec, wall time apart, its vehicles
    stepped as lanes (counted: groups of 2 here); a failed run's place holds its error."""
    together = lanes_counted(monkeypatch)
    text = shortened((CONFIGS / "paper.toml").read_text(), 30.0).encode()
    specs = [RunSpec((("comms.loss", loss),), seed) for loss in (0.0, 0.4) for seed in range(2)]
    # A scenario its settings make invalid amid the good runs (the review found every row after it shifted by one).
    specs.insert(1, RunSpec((("path_following.k1", -1.0),), 0))
    specs.append(RunSpec((("scenario.step", 1.0),), 0))
    many = run_many("paper.toml", text, specs)
    assert isinstance(many[1], ScenarioError) and str(many[1]).startswith("paper.toml: path_following.k1: ")
    assert isinstance(many[-1], SimulationError)
    assert together[0] >= 4 * 3 * 300  # the four good runs' vehicles, every step, as lanes
    for spec, row in zip(specs[:-1], many[:-1], strict=True):
        if spec.settings[0][0] == "path_following.k1":
            continue
        assert not isinstance(row, Exception)
        alone: dict[str, Any] = run_one("paper.toml", text, spec, "inprocess")
        assert {**row, "wall_s": None} == {**alone, "wall_s": None}


@pytest.mark.parametrize(
    ("runs", "jobs", "sizes"),
    [
        (200, 2, [50] * 4),
        (1000, 2, [63] * 8 + [62] * 8),
        (5, 2, [3, 2]),
        (1, 4, [1]),
        (130, 1, [44, 43, 43]),
        (9, 4, [3, 2, 2, 2]),
    ],
)
def test_batches_are_even_and_a_multiple_of_the_workers(runs, jobs, sizes):
    specs = [RunSpec((), seed) for seed in range(runs)]
    got = batches(specs, jobs)
    assert [len(b) for b in got] == sizes and [s for b in got for s in b] == specs


@pytest.mark.parametrize("durations", [(100.0, 400.0), (100.0, 200.0, 300.0, 400.0), (400.0, 100.0)])
def test_workers_given_batches_in_grid_order_finish_near_together(durations):
    """Batches go to the first free worker in grid order (seeds innermost), so a swept duration puts cheap and dear
    runs in different batches; the sweep gives such runs (their steps x vehicles unlike) at least
    BATCHES_PER_WORKER batches each, and the last worker ends within 1.25x of the balanced time (Graham's
    list-scheduling bound: one batch past the mean). With one batch a worker the review measured 1.6x for durations
    100 and 400 s."""
    specs = [RunSpec((("scenario.duration", d),), seed) for d in durations for seed in range(10)]
    sent: list[list[RunSpec]] = []
    submit = lambda work, name, text, batch: sent.append(batch)  # noqa: E731
    sizes = (int(min(durations)) * 30, int(max(durations)) * 30)  # steps x 3 vehicles at 0.1 s
    _submitted(submit, CONFIGS / "paper.toml", b"", specs, "inprocess", False, 2, sizes)  # type: ignore[arg-type]
    assert len(sent) >= 2 * BATCHES_PER_WORKER
    loads = [0.0, 0.0]
    for batch in sent:
        loads[loads.index(min(loads))] += sum(spec.settings[0][1] for spec in batch)
    assert max(loads) <= 1.25 * sum(loads) / 2, loads


def test_a_failed_run_of_a_batch_is_named_and_the_batch_rows_kept(tmp_path):
    """Combinations of swept values no scenario takes (each value alone is valid, so the sweep starts) in a batch
    with good runs: the sweep ends naming the first of them, and every other run of the batch has its row (the
    review found the batch's first run named with another's error, the rows after a failure lost, and the rows after a
    scenario its settings make invalid shifted by one: this valid 10.1 s run was not kept)."""
    from supervisor.tools.sweep import Param, sweep

    scenario = tmp_path / "paper.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 10.0))
    params = [Param("scenario.duration", (10.0, 10.1)), Param("scenario.step", (0.2, 0.1))]  # 10.1 / 0.2 is not whole
    with pytest.raises(
        SimulationError, match=r"sweep run duration=10.1_step=0.2_seed=0_\w+ failed: paper\.toml: scenario\.step: "
    ):
        sweep(scenario, params, 1, 1, tmp_path / "out", progress=None)
    kept = sorted(p.name.split("_seed")[0] for p in (tmp_path / "out" / "runs").glob("*.json"))
    assert kept == ["duration=10.0_step=0.1", "duration=10.0_step=0.2", "duration=10.1_step=0.1"]


def test_a_failed_run_does_not_end_the_others_and_results_hold_their_rows(tmp_path):
    """A run that fails is a result of the study: the other workers' runs go on, results.csv holds their rows, and
    the sweep ends naming the failed one. Before, the first failure stopped every worker and wrote no results.csv (a
    new user lost the rows of a batch already under way)."""
    from supervisor.tools.sweep import Param, sweep

    scenario = tmp_path / "paper.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 10.0))
    params = [Param("scenario.duration", (10.0, 10.1)), Param("scenario.step", (0.2, 0.1))]  # 10.1 / 0.2 is not whole
    with pytest.raises(SimulationError, match=r"failed: .* \(results\.csv holds the 3 runs that ended; a rerun"):
        sweep(scenario, params, 1, 2, tmp_path / "out", progress=None)
    with (tmp_path / "out" / "results.csv").open() as stream:
        assert len(list(csv.DictReader(stream))) == 3


def test_a_sweep_that_fails_says_so_in_one_line_and_its_idle_workers_end_quietly(tmp_path):
    """A failed run ends the sweep (once the others have); its workers are stopped (sweep._stop_workers), and one that
    waits for work ends quietly (sweep._worker_signal): the stop raised in the pool's loop printed a traceback per idle
    worker."""
    from tests.procs import cpf

    scenario = tmp_path / "paper.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 10.0))
    grid = ["--param", "scenario.duration=10.0,10.1", "--param", "scenario.step=0.2,0.1", "--seeds", "1"]
    done = cpf("sweep", str(scenario), *grid, "--jobs", "1", "--out", "sw", cwd=tmp_path)  # idle once its batch ends
    assert done.returncode == 1
    assert "Traceback" not in done.stderr, done.stderr
    (last,) = done.stderr.strip().splitlines()[-1:]
    assert last.startswith("cpf: error: sweep run duration=10.1_step=0.2_seed=0_"), done.stderr


def test_a_batch_of_long_runs_of_large_fleets_holds_fewer_runs():
    """batch_limit from what a run's series really hold at its end (the builder's array and the Series it hands
    back: BYTES_PER_VEHICLE_STEP, measured here on a filled builder), so that a batch's runs hold at most
    BATCH_MEMORY together: the paper (3 AUVs, 4000 steps) 64 a batch, 50 AUVs for an hour at 0.1 s 5."""
    import dataclasses

    from supervisor.analysis.series import BYTES_PER_VEHICLE_STEP, SeriesBuilder
    from supervisor.tools.sweep_runs import BATCH_MEMORY, MAX_BATCH, batch_limit

    vehicles, steps = 4, 3000
    builder = SeriesBuilder(range(1, vehicles + 1), steps, 0.1)
    builder._grow(steps - 1)
    series = builder.series()
    arrays = [v for f in dataclasses.fields(series) if isinstance(v := getattr(series, f.name), np.ndarray)]
    held = builder._data.nbytes + sum(a.nbytes for a in arrays) - series.t.nbytes
    assert held == BYTES_PER_VEHICLE_STEP * vehicles * steps
    assert batch_limit(3 * 4000) == MAX_BATCH
    assert batch_limit(50 * 36000) == 5 and 5 * 50 * 36000 * BYTES_PER_VEHICLE_STEP <= BATCH_MEMORY
    assert batch_limit(10**12) == 1
    assert [len(b) for b in batches([RunSpec((), s) for s in range(12)], 1, 5)] == [4, 4, 4]
    from supervisor.tools.sweep import Param, _check_values

    paper = CONFIGS / "paper.toml"
    assert _check_values(paper, [Param("scenario.duration", (10.0, 800.0))]) == (100 * 3, 8000 * 3)
    assert _check_values(paper, [Param("comms.loss", (0.1, 0.2))]) == (4000 * 3, 4000 * 3)  # alike: one batch a worker


def test_a_worker_parts_its_batch_by_its_runs_own_size(monkeypatch):
    """The sweep sizes its batches from each swept value alone (sweep._check_values); a combination (a longer run at
    a shorter step) can be far larger, so run_many parts its batch by each run's own steps x vehicles, every part
    within BATCH_MEMORY (the review found 7.2 GiB a batch where 1 GiB was meant), the rows still run_one's."""
    import supervisor.engine.batch
    from supervisor.analysis.series import BYTES_PER_VEHICLE_STEP
    from supervisor.tools import sweep_runs

    monkeypatch.setattr(sweep_runs, "BATCH_MEMORY", 3 * 3 * 100 * BYTES_PER_VEHICLE_STEP)  # three 10 s paper runs
    parts: list[int] = []
    inner = supervisor.engine.batch.run_batch

    def parted(runs: Any) -> Any:
        parts.append(sum(steps_of(run.scenario) * len(run.scenario.vehicle_ids) for run in runs))
        return inner(runs)

    monkeypatch.setattr(supervisor.engine.batch, "run_batch", parted)
    text = shortened((CONFIGS / "paper.toml").read_text(), 10.0).encode()
    specs = [RunSpec((("scenario.duration", 10.0),), seed) for seed in range(4)]
    specs.insert(2, RunSpec((("scenario.duration", 20.0), ("scenario.step", 0.05)), 0))  # 400 steps
    many = run_many("paper.toml", text, specs)
    assert parts == [600, 1200, 600]  # [10 s, 10 s], [20 s at 0.05 s], [10 s, 10 s]
    for spec, row in zip(specs, many, strict=True):
        assert isinstance(row, dict)
        assert {**row, "wall_s": None} == {**run_one("paper.toml", text, spec, "inprocess"), "wall_s": None}


def test_a_run_whose_summary_fails_ends_alone_in_its_batch(monkeypatch):
    """A run's row is made in its own turn: were its summary to raise, that run's place holds the error and the
    other runs of the batch keep their rows (before, run_many failed as a whole and the batch's every run with it)."""
    from supervisor.tools import sweep_runs

    inner = sweep_runs.row_of

    def picky(spec: RunSpec, scenario: Any, result: Any) -> dict[str, Any]:
        if spec.seed == 1:
            raise ValueError("no summary for seed 1")
        return inner(spec, scenario, result)

    monkeypatch.setattr(sweep_runs, "row_of", picky)
    text = shortened((CONFIGS / "paper.toml").read_text(), 5.0).encode()
    many = run_many("paper.toml", text, [RunSpec((), seed) for seed in range(3)])
    assert isinstance(many[1], ValueError) and all(isinstance(row, dict) for row in (many[0], many[2]))

"""The inputs issue 14 found ending in a traceback, a hang, gigabytes or a corrupt log, one by one: each now gives
the usual one-line error (exit 2) before anything starts, or runs as it should."""

from __future__ import annotations

import contextlib
import fcntl
import io
import math
import tracemalloc

import numpy as np
import pytest
from msgspec.structs import replace

from comms.records.state import StateReport
from supervisor.analysis.series import SeriesBuilder
from supervisor.cli import main
from supervisor.errors import ScenarioError
from supervisor.record.recorder import Recorder, read_messages
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf
from tests.test_faults_e2e import records

PAPER = CONFIGS / "paper.toml"
SHORT = ["--engine", "inprocess", "--quiet", "--set", "scenario.duration=1", "--set", "faults=[]"]


def cli(*argv: str) -> tuple[int, list[str]]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(list(argv))
        except SystemExit as exc:  # argparse: a bad option value
            code = int(exc.code or 0)
    return code, err.getvalue().splitlines()


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ("--set=scenario.duration=1e7", "scenario.duration"),
        ("--set=scenario.step=1e-300", "scenario.step"),
        ("--set=vehicles.0.velocity=[-1e308,0,0]", "vehicles[0].velocity[0]"),
        ("--set=comms.sound_speed=0", "comms.sound_speed"),
        ("--set=coordination.v_r=1e308", "coordination.v_r"),
        ("--set=coordination.v_r=1000", "coordination.v_r"),  # finite, but 395 m/s along vehicle 3's helix
        ("--set=vehicles.0.gamma0=1e308", "vehicles[0].gamma0"),
        ("--set=scenario.seed=18446744073709551616", "scenario.seed"),
        ("--set=scenario.name='../../x'", "scenario.name"),
        ("--set=vehicle.overrides.mass=[0.0,1.0,1.0]", "vehicle.overrides.mass"),
        ("--fault=kind=clock_skew,vehicle=1,offset=-1e6,start=0", "faults[1].offset"),
        ("--fault=kind=clock_skew,vehicle=1,offset=1e308,start=0", "faults[1].offset"),
        ("--fault=kind=gamma_offset,vehicle=1,offset=1e308,start=0", "faults[1].offset"),
        ("--fault=kind=speed_cap,vehicle=1,gamma_dot_max=-1e308,start=0", "faults[1].gamma_dot_max"),
    ],
)
def test_each_value_the_issue_found_is_refused_in_one_line_before_the_run(tmp_path, change, field):
    out = tmp_path / "r.mcap"
    code, lines = cli("run", str(PAPER), "--engine", "inprocess", "--quiet", change, "--out", str(out))
    assert code == 2
    assert lines[0].startswith(f"cpf: error: {PAPER}: {field}: ")
    assert not out.exists()  # nothing started


def test_arrays_nested_500_deep_are_refused_in_one_line(tmp_path):
    source = tmp_path / "deep.toml"
    source.write_text(PAPER.read_text().replace("seed = 0", "seed = " + "[" * 500 + "]" * 500))
    assert cli("validate", str(source)) == (
        2,
        [f"cpf: error: {source}: invalid TOML: arrays or tables nested too deeply (at most 10 levels)"],
    )


@pytest.mark.parametrize("speed", ["inf", "nan", "-inf", "1e400", "0"])
def test_speed_inf_or_nan_is_refused_before_the_run(speed):
    code, lines = cli("run", str(PAPER), "--clock", "realtime", "--speed", speed)
    assert code == 2 and "argument --speed" in lines[-1]


def test_out_a_directory_or_under_a_file_is_refused_before_the_run(tmp_path):
    (tmp_path / "file").write_text("x")
    for out, problem in [(tmp_path, "is a directory"), (tmp_path / "file" / "r.mcap", "is a file, not a directory")]:
        code, lines = cli("run", str(PAPER), *SHORT, "--out", str(out))
        assert code == 2 and lines == [f"cpf: error: {PAPER}: --out: {lines[0].split('--out: ')[1]}"]
        assert problem in lines[0]


def test_metrics_a_directory_is_refused_before_the_run_not_after(tmp_path):
    out = tmp_path / "r.mcap"
    code, lines = cli("run", str(PAPER), *SHORT, "--out", str(out), "--metrics", str(tmp_path))
    assert code == 2 and lines == [f"cpf: error: {PAPER}: --metrics: is a directory, not a file, got {tmp_path}"]
    assert not out.exists()  # the run never started


def test_a_log_in_use_is_refused_and_left_whole(tmp_path):
    """Two runs on one --out: the second is refused before it starts and does not touch the first's file."""
    out = tmp_path / "r.mcap"
    with out.open("wb") as held:  # locked as the first run's recorder holds it
        fcntl.flock(held.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        held.write(b"the first run's log")
        held.flush()
        code, lines = cli("run", str(PAPER), *SHORT, "--out", str(out))
        assert code == 2 and lines == [
            f"cpf: error: {PAPER}: --out: in use: another run is writing this log, got {out}"
        ]
        with pytest.raises(ScenarioError, match="in use"):  # the recorder's own lock, without the CLI's check
            Recorder(out)
        assert out.read_bytes() == b"the first run's log"
    assert cli("run", str(PAPER), *SHORT, "--out", str(out))[0] == 0  # released: a new run may overwrite it
    assert read_messages(out)


def test_a_log_is_never_written_over_by_the_command_that_reads_it(tmp_path):
    """cpf resim LOG --out LOG wrote the re-simulation over the recording (found by a new user); recover already
    refused it. Both now say so in one line, exit 2, and leave the log as it was."""
    log = tmp_path / "r.mcap"
    assert cli("run", str(PAPER), *SHORT, "--out", str(log))[0] == 0
    recorded = log.read_bytes()
    for command in ("resim", "recover"):
        code, lines = cli(command, str(log), "--out", str(tmp_path / "." / "r.mcap"))
        assert code == 2 and len(lines) == 1 and "--out: the same file as the log it reads" in lines[0], lines
    assert log.read_bytes() == recorded


def report(k: int) -> StateReport:
    """Vehicle 2's state at step k, |p - p_d| = 5."""
    identity = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    zero = (0.0, 0.0, 0.0)
    return StateReport(k * 0.1, k, 2, float(k), 1.0, zero, identity, zero, zero, (3.0, 4.0, 0.0), (), 0.0, 0.0, 0, ())


def test_the_series_grows_with_the_run_instead_of_allocating_every_step_up_front():
    steps = 2_000_000  # 144 MB of float64 for 3 vehicles if allocated up front
    tracemalloc.start()
    try:
        builder = SeriesBuilder((1, 2, 3), steps, 0.1)
        for k in (0, 1, 5, 1500):
            builder.add(report(k))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10_000_000
    small = SeriesBuilder((1, 2, 3), 4000, 0.1)
    for k in (0, 1, 5, 1500, 3999):
        small.add(report(k))
    series = small.series()
    assert series.t.shape == (4000,) and series.gamma.shape == (4000, 3)
    filled = ~np.isnan(series.gamma)
    assert filled.sum() == 5 and list(np.flatnonzero(filled[:, 1])) == [0, 1, 5, 1500, 3999]
    assert series.gamma[1500, 1] == 1500.0 and series.path_error[3999, 1] == 5.0


def test_a_clock_skewed_before_zero_is_refused_alike_by_both_engines_and_a_later_one_runs_the_same(tmp_path):
    """offset=-0.5 from t=0 would stamp data at -0.5 s, which the modem frame (u32 ms) cannot carry: the in-process
    engine crashed, the Zenoh broker dropped five transmissions. Both now refuse it with the same line; from t=1 the
    same skew runs, identically in both engines."""
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened(PAPER.read_text(), 3.0))
    refused = {}
    for engine in ("zenoh", "inprocess"):
        skew = ["--fault", "kind=clock_skew,vehicle=1,offset=-0.5,start=0", "--set", "faults=[]"]
        done = cpf("run", str(scenario), "--engine", engine, *skew, "--out", f"{engine}.mcap", "--quiet", cwd=tmp_path)
        assert done.returncode == 2 and not (tmp_path / f"{engine}.mcap").exists()
        refused[engine] = done.stderr
    assert refused["zenoh"] == refused["inprocess"]
    assert "faults[0].offset: vehicle 1's clock would read -0.5 s at t = 0 s" in refused["zenoh"]
    for engine in ("zenoh", "inprocess"):
        skew = ["--fault", "kind=clock_skew,vehicle=1,offset=-0.5,start=1", "--set", "faults=[]"]
        done = cpf(
            "run", str(scenario), "--engine", engine, *skew, "--out", f"ok_{engine}.mcap", "--quiet", cwd=tmp_path
        )
        assert done.returncode == 0, done.stderr
    zen, inp = records(tmp_path / "ok_zenoh.mcap"), records(tmp_path / "ok_inprocess.mcap")
    assert zen == inp
    sent = [m for topic, _, m in read_messages(tmp_path / "ok_zenoh.mcap") if topic == "cpf/vehicle/1/tx"]
    assert len(sent) == 30  # every transmission went out, none dropped
    assert all(m["stamp"] == pytest.approx(m["t"] - (0.5 if m["t"] > 0.95 else 0.0)) for m in sent)


def test_a_huge_path_error_in_a_state_is_a_finite_series_value_without_a_warning():
    """A state's error is a diagnostic that needs only be a number: |(1e300, 1e300, 0)| overflowed in the norm's
    squares (a RuntimeWarning, inf), found by the forged-bus property test."""
    builder = SeriesBuilder((1, 2, 3), 10, 0.1)
    builder.add(replace(report(1), error=(1e300, 1e300, 0.0)))
    builder.add(replace(report(2), error=(-1e308, 1e308, 1e308)))
    assert builder.series().path_error[1, 1] == pytest.approx(math.sqrt(2) * 1e300)
    assert builder.series().path_error[2, 1] == pytest.approx(math.sqrt(3) * 1e308)

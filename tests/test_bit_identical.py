"""Restructurings keep results bit-identical, and so does another CPU: every reference run (the paper
scenario, paper_acoustic, reference_everything.toml, a 10-seed fault soak; tests/run_digest.py) records exactly
what the code recorded when tests/data/run_digests.json was written, and a selection of them does so again with
numpy, OpenBLAS and glibc's libm made to run the kernels of older CPUs (tests/cpu_targets.py): a result that depends
on the CPU fails here, on any one machine, instead of on the next machine CI runs on (issue 27).

A change meant to change results regenerates the file (`python -m tests.run_digest`) and says so in its commit.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.conftest import shortened
from tests.cpu_targets import PROBE, targets
from tests.run_digest import FIXTURE, reference_runs, run_and_digest

EXPECTED = json.loads(FIXTURE.read_text())
RUNS = reference_runs()
TARGETS = targets()
# The run that computes everything (navigation, currents and the current observer, mismatch, fading, event-triggered
# transmission, saturation: tests/data/reference_everything.toml, written to cover every computation for this test)
# and a fault soak, in process: the arithmetic is the same code in both engines, and the engines record the same
# (test_both_engines_recorded_the_same_reference_runs), so the Zenoh runs would repeat these at three times the
# cost, and the paper and acoustic runs (400 s each) go through a subset of the same code.
ON_OTHER_CPUS = ("everything-inprocess", "soak3-inprocess")


def test_the_fixture_covers_every_reference_run():
    assert sorted(EXPECTED) == sorted(RUNS)


@pytest.mark.parametrize("name", sorted(RUNS))
def test_a_reference_run_records_what_it_recorded_before(tmp_path, name):
    text, extra = RUNS[name]
    assert run_and_digest(name, text, extra, tmp_path) == EXPECTED[name]


def test_both_engines_recorded_the_same_reference_runs():
    """Every reference run on both engines has one record: the Zenoh engine reproduces the in-process one bit for
    bit (both are checked against the fixture above)."""
    engines = {name.rpartition("-")[0] for name in RUNS if name.endswith("-zenoh")}
    assert engines == {"paper", "acoustic", "everything"}
    assert all(EXPECTED[f"{name}-zenoh"] == EXPECTED[f"{name}-inprocess"] for name in engines)


def _probe(env: dict[str, str]) -> list[str]:
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True, env=env)
    return done.stdout.split()


def test_the_cpu_targets_change_what_the_cpu_decides():
    """The switches bite on this machine (else the test below would pass whatever the code did): each target changes
    libm's last bits against this machine's own variant, and its BLAS kernel's against OpenBLAS's Haswell kernel (the
    FMA one any x86-64 machine we run on has). The suite may itself run under a target (issue 27's acceptance), so
    'here' is the environment without the switches this file sets."""
    native = {k: v for k, v in os.environ.items() if k not in ("GLIBC_TUNABLES", "NPY_DISABLE_CPU_FEATURES")}
    libm_here = _probe(native)[0]
    blas_fma = _probe({**native, "OPENBLAS_CORETYPE": "Haswell"})[1]
    for name, env in TARGETS.items():
        libm, blas = _probe({**os.environ, **env})
        assert libm != libm_here, f"{name}: GLIBC_TUNABLES had no effect on libm"
        assert blas != blas_fma, f"{name}: OPENBLAS_CORETYPE had no effect on BLAS"


@pytest.mark.parametrize(("target", "name"), [(t, n) for t in sorted(TARGETS) for n in ON_OTHER_CPUS])
def test_a_reference_run_records_the_same_on_another_cpu(tmp_path, target, name):
    text, extra = RUNS[name]
    assert run_and_digest(name, text, extra, tmp_path, TARGETS[target]) == EXPECTED[name]


# A run's summary as a sweep takes it: its series (the rows of a sweep and `cpf run`'s summary come from these arrays).
SERIES = """
import hashlib, io, sys
from pathlib import Path
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
text = Path(sys.argv[1]).read_text()
scenario = parse_scenario(text, sys.argv[1])
s = run_inprocess(scenario, sys.argv[1], text, None, 0, Progress(1.0, io.StringIO(), enabled=False)).series
arrays = (s.gamma, s.gamma_dot, s.path_error, s.inputs, s.surge)
print(hashlib.sha256(b"".join(a.tobytes() for a in arrays)).hexdigest())
"""


@pytest.mark.parametrize("target", sorted(TARGETS))
def test_a_runs_summary_series_are_the_same_on_another_cpu(tmp_path, target):
    """What a run's summary and a sweep's row are computed from (gamma, gamma_dot, |p - p_d|, inputs, surge speed at
    every step) is the same on another CPU's kernels as on OpenBLAS's FMA (Haswell) one: |p - p_d| took BLAS's dot,
    whose last bits differ between those kernels."""
    path = tmp_path / "paper.toml"
    path.write_text(shortened(RUNS["paper-inprocess"][0], 30.0))
    here = {**os.environ, "OPENBLAS_CORETYPE": "Haswell"}

    def digest(env: dict[str, str]) -> str:
        return subprocess.run([sys.executable, "-c", SERIES, str(path)], capture_output=True, text=True, check=True,
                              env=env).stdout.strip()  # fmt: skip

    assert digest({**os.environ, **TARGETS[target]}) == digest(here)

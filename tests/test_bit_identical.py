"""Restructurings keep results bit-identical, and so does another CPU: every reference run (the paper
scenario, paper_acoustic, reference_everything.toml, a 20-seed fault soak; tests/run_digest.py) records exactly
what the code recorded when tests/data/run_digests.json was written, and a selection of them does so again with
numpy, OpenBLAS and glibc's libm made to run the kernels of older CPUs (tests/cpu_targets.py): a result that depends
on the CPU fails here, on any one machine, instead of on the next machine CI runs on (issue 27).

A change meant to change results regenerates the file (`python -m tests.run_digest`) and says so in its commit.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.cpu_targets import PROBE, targets
from tests.run_digest import FIXTURE, reference_runs, run_and_digest

EXPECTED = json.loads(FIXTURE.read_text())
RUNS = reference_runs()
TARGETS = targets()
# Both engines; the ideal channel, the acoustic one, and the run that computes everything (navigation, currents,
# mismatch, fading: tests/data/reference_everything.toml); a fault soak.
ON_OTHER_CPUS = ("paper-inprocess", "paper-zenoh", "acoustic-inprocess", "everything-inprocess", "everything-zenoh",
                 "soak3-inprocess")  # fmt: skip


def test_the_fixture_covers_every_reference_run():
    assert sorted(EXPECTED) == sorted(RUNS)


@pytest.mark.parametrize("name", sorted(RUNS))
def test_a_reference_run_records_what_it_recorded_before(tmp_path, name):
    text, extra = RUNS[name]
    assert run_and_digest(name, text, extra, tmp_path) == EXPECTED[name]


def _probe(env: dict[str, str]) -> list[str]:
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True, env=env)
    return done.stdout.split()


@pytest.mark.parametrize("target", sorted(TARGETS))
def test_each_cpu_target_changes_what_the_cpu_decides(target, monkeypatch):
    """The switches bite on this machine: libm's and BLAS's last bits change under them (else the test below would
    pass whatever the code did)."""
    import os

    here = _probe(dict(os.environ))
    there = _probe({**os.environ, **TARGETS[target]})
    assert there[0] != here[0], "libm's results did not change: GLIBC_TUNABLES had no effect"
    assert there[1] != here[1], "BLAS's results did not change: OPENBLAS_CORETYPE had no effect"


@pytest.mark.parametrize(("target", "name"), [(t, n) for t in sorted(TARGETS) for n in ON_OTHER_CPUS])
def test_a_reference_run_records_the_same_on_another_cpu(tmp_path, target, name):
    text, extra = RUNS[name]
    assert run_and_digest(name, text, extra, tmp_path, TARGETS[target]) == EXPECTED[name]

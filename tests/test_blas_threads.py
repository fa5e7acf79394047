"""cpf runs numpy's BLAS on one thread in every process it is (supervisor.cli.BLAS_THREADS), unless the user said
otherwise: OpenBLAS's workers only spin on our small matrices and take CPU from the fleet's processes."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.procs import ROOT

# A cpf command in a fresh interpreter, then numpy: its threads and the variable, as the processes of a run see them.
PROBE = """
import os, sys
from supervisor.cli import main
main(["presets"])
import numpy
sys.stderr.write(f"{os.environ.get('OPENBLAS_NUM_THREADS')} {len(os.listdir('/proc/self/task'))}\\n")
"""


def _probe(env: dict[str, str]) -> tuple[str, int]:
    done = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    value, threads = done.stderr.strip().splitlines()[-1].split()
    return value, int(threads)


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts threads through Linux's /proc")
def test_numpy_runs_one_blas_thread_in_a_cpf_process() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    value, threads = _probe(env)
    assert value == "1"
    assert threads == 1  # without the setting, OpenBLAS starts one worker per core (2 on the CI machine)


def test_a_thread_count_the_user_set_is_kept() -> None:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "2"}
    value, _ = _probe(env)
    assert value == "2"

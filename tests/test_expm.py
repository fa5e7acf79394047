"""The stability analysis's matrix exponential (supervisor.config.stability.expm, Higham 2005's [13/13] Pade with
scaling and squaring) against scipy.linalg.expm, which runs the same algorithm: the same matrices to a few units of
roundoff, on random matrices of 1-norm 1e-3 to 1e3, and on the analysis's own generators."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg

from supervisor.config.scenario import load_scenario
from supervisor.config.stability.expm import block_diag, expm
from supervisor.config.stability.monodromy import Layout
from supervisor.config.stability.scenario import setting_of
from tests.conftest import CONFIGS


@pytest.mark.parametrize("norm", [1e-3, 0.5, 5.0, 5.4, 60.0, 1e3])
@pytest.mark.parametrize("n", [1, 2, 7, 30])
def test_expm_is_scipys(n, norm):
    rng = np.random.default_rng(n * 1000 + int(norm * 10))
    a = rng.standard_normal((n, n))
    a *= norm / np.linalg.norm(a, 1)
    if norm >= 60.0:
        a -= norm * np.eye(n)  # a stable generator: exp(a) not overflowing, as the analysis's flows
    want = scipy.linalg.expm(a)
    # Both are backward stable, not bit-equal (scipy picks a lower Pade degree for small norms): they agree to the
    # problem's conditioning times eps, ~1e-12 after the 5 squarings of norm 1e3.
    assert np.linalg.norm(expm(a) - want, 1) <= 1e-10 * np.linalg.norm(want, 1)


@pytest.mark.parametrize("config", ["paper.toml", "examples/helix_ring_30s.toml", "examples/circles.toml"])
def test_expm_of_the_analysis_generators(config):
    setting = setting_of(load_scenario(CONFIGS / config))
    layout = Layout(setting.loop, setting.sampling())
    for tau in (0.01, setting.period, 10 * setting.period):
        want = scipy.linalg.expm(layout.generator * tau)
        assert np.allclose(expm(layout.generator * tau), want, rtol=1e-12, atol=1e-14)
    blocks = [np.full((1, 1), 2.0), np.arange(6.0).reshape(2, 3), np.eye(2)]
    assert np.array_equal(block_diag(*blocks), scipy.linalg.block_diag(*blocks))


def test_validating_a_scenario_does_not_import_scipy():
    """The reason for the module: scipy's import (0.6-0.9 s of CPU) in every process that checks a scenario."""
    code = (
        "import sys; from pathlib import Path; from supervisor.config.scenario import load_scenario; "
        "from supervisor.config.scenario_checks import scenario_warnings; "
        f"scenario_warnings(load_scenario(Path({str(CONFIGS / 'paper.toml')!r}))); "
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"

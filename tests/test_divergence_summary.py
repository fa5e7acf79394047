"""A diverging run says so (issue 28): that the coordination loop diverged, since when, and what to look at (issue
23's stability check), not only "OUTSIDE" and "never below" (supervisor.analysis.divergence)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from supervisor.analysis.divergence import divergence, format_divergence
from supervisor.analysis.summary import Series
from tests.conftest import CONFIGS

DT = 0.1
T = np.arange(0.0, 400.0, DT)


def series(gamma: np.ndarray, gamma_dot: np.ndarray) -> Series:
    return Series((1, 2, 3), T, gamma, gamma_dot, np.full_like(gamma, 0.5))


def growing_from(onset: float, rate: float) -> Series:
    """Three vehicles whose gammas oscillate apart at `rate` 1/s from `onset` on (tiny and steady before)."""
    envelope = 1e-3 * np.exp(rate * np.clip(T - onset, 0.0, None))
    wave = envelope * np.sin(2 * np.pi * T / 12.0)
    offsets = np.stack([wave, -wave, 0.5 * wave], axis=1)
    gamma = T[:, None] + offsets
    gamma_dot = 1.0 + np.gradient(offsets, DT, axis=0)
    return series(gamma, gamma_dot)


def test_a_growing_oscillation_is_a_divergence_since_its_onset():
    found = divergence(growing_from(150.0, 0.08), v_r=1.0, tolerance=0.01)
    assert found is not None
    assert 150.0 - 20.0 <= found.since <= 150.0 + 20.0  # the growth's start, to a window (20 s)
    assert found.error_to > 1e3 * found.error_from and found.rate_off > 1.0
    text = format_divergence(found, 1.0, 0.08, "paper.toml")
    first, second = text.splitlines()
    assert first.startswith(f"the coordination loop DIVERGED from about t = {found.since:.0f} s: its error grew from")
    assert "away from v_r = 1" in first
    assert second.startswith("look at: cpf stability paper.toml (docs/stability.md): it predicts this")


@pytest.mark.parametrize(
    "run",
    [
        "converging",  # the error decays
        "lagging",  # a vehicle held at half speed to the end (a fault still on): the error grows, gamma_dot near v_r
        "steady",  # a constant offset
    ],
)
def test_a_run_that_did_not_diverge_is_not_called_diverged(run):
    if run == "converging":
        s = growing_from(0.0, -0.02)
    elif run == "lagging":
        rates = np.where(T[:, None] > 300.0, np.array([1.0, 0.5, 1.0]), 1.0)
        s = series(np.cumsum(rates, axis=0) * DT, rates)
    else:
        s = series(T[:, None] + np.array([0.0, 0.2, 0.4]), np.ones((T.size, 3)))
    assert divergence(s, v_r=1.0, tolerance=0.01) is None


def test_what_to_look_at_follows_the_stability_verdict():
    found = divergence(growing_from(150.0, 0.08), v_r=1.0, tolerance=0.01)
    assert found is not None
    converges = format_divergence(found, 1.0, -0.05, "s.toml").splitlines()[1]
    assert "it predicts convergence with these links (decay 0.05 1/s)" in converges
    assert "inputs at their limits" in converges
    unknown = format_divergence(found, 1.0, None, "s.toml").splitlines()[1]
    assert unknown == (
        "look at: cpf stability s.toml (docs/stability.md): whether the loop converges with these links, "
        "and what it tolerates"
    )
    unmodelled = format_divergence(found, 1.0, None, "s.toml", "coordination.law: ..., got 'saturated'")
    assert unmodelled.splitlines()[1] == "not predicted: coordination.law: ..., got 'saturated' (docs/stability.md)"


# The paper's fleet with k = 1, first_order prediction and a message every 5 s (cpf stability: the error grows at
# 0.08 1/s), without the correction's bound.
UNSTABLE = ["comms.transmit.period=5", "coordination.predictor=first_order", "coordination.schedule=none",
            "coordination.k=1.0", "saturation.correction=none", "faults=[]"]  # fmt: skip


def run_unstable(tmp_path: Path, *args: str) -> tuple[Path, subprocess.CompletedProcess[str]]:
    """cpf run of the UNSTABLE paper fleet for 100 s: the scenario file and what the command did."""
    from tests.conftest import shortened
    from tests.procs import cpf

    scenario = tmp_path / "paper.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 100.0))
    sets = [arg for s in UNSTABLE for arg in ("--set", s)]
    return scenario, cpf("run", str(scenario), "--quiet", "--no-foxglove", *args, *sets, cwd=tmp_path)


def test_cpf_run_says_that_a_diverging_loop_diverged_and_what_to_look_at(tmp_path):
    """The UNSTABLE fleet, 100 s in process; the paper run as it is (converging, fault and all) says nothing of the
    kind."""
    scenario, done = run_unstable(tmp_path, "--engine", "inprocess")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    said = next(i for i, line in enumerate(lines) if line.startswith("the coordination loop DIVERGED from about t = "))
    assert lines[said + 1].startswith(f"look at: cpf stability {scenario} (docs/stability.md): it predicts this")
    # and the log's report and the API's summary give the verdict --metrics gives (they lacked it: a new user's study)
    from supervisor.analysis.metrics import run_metrics
    from supervisor.analysis.report import load_run

    (log,) = tmp_path.glob("runs/*.mcap")
    verdict = run_metrics(load_run(log))["divergence"]
    assert verdict is not None and lines[said].startswith(
        f"the coordination loop DIVERGED from about t = {verdict['since']:.0f} s"
    )


def test_on_the_zenoh_engine_the_bounds_stop_a_diverging_loop_and_say_it_may_be_one(tmp_path):
    """The UNSTABLE fleet over Zenoh: the intake's plausibility bounds (comms.records.plausible) stop the run once a
    path parameter's rate leaves what the vehicle can follow, and the line says that a diverging loop does that, not
    only a vehicle that lies (it said 'implausible' alone)."""
    _, done = run_unstable(tmp_path, "--out", "r.mcap")
    errors = [line for line in done.stderr.splitlines() if line.startswith("cpf: error")]
    assert done.returncode == 1 and len(errors) == 1, done.stderr
    assert "implausible" in errors[0] and "its coordination loop diverged or it lies" in errors[0], errors

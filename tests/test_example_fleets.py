"""The README's two example fleets on real links ("Coordination on slow links"), run whole and held to the figures
it gives, to their printed digits: micromodem_tdma (six AUVs, Micro-Modem rate 0 on 24 s TDMA frames, 30 % loss in
bursts, event-triggered: error 13 at most, 0.015 at 1200 s, path 1.09 m) and helix_ring_30s (five in a ring on 30 s
frames, 30 % bursty loss, a speed_cap fault: 45 at most, 0.18 at 900 s, 0.54 at most over the last 50 s, path
1.16 m). They were held by running them by hand alone (a new user's audit); tests/test_examples.py runs them
shortened. ~25 s."""

from __future__ import annotations

import io

import numpy as np

from supervisor.analysis.summary import coordination_error
from supervisor.config.scenario import load_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from tests.conftest import CONFIGS


def figures(name: str) -> tuple[float, float, float, float]:
    """(largest coordination error, at the end, largest over the last 50 s, largest path error after the transient)."""
    path = CONFIGS / "examples" / name
    sc = load_scenario(path)
    quiet = Progress(sc.scenario.duration, io.StringIO(), enabled=False)
    series = run_inprocess(sc, str(path), path.read_text(), None, sc.scenario.seed, quiet).series
    error = coordination_error(series.gamma)
    last = series.t >= series.t[-1] - 50.0
    path_error = series.path_error[series.t >= sc.report.transient]
    return float(np.nanmax(error)), float(error[-1]), float(np.nanmax(error[last])), float(np.nanmax(path_error))


def test_micromodem_tdma_as_the_readme_says():
    most, end, _, path = figures("micromodem_tdma.toml")
    assert (round(most), round(end, 3), round(path, 2)) == (13, 0.015, 1.09)


def test_helix_ring_30s_as_the_readme_says():
    most, end, recent, path = figures("helix_ring_30s.toml")
    assert (round(most), round(end, 2), round(recent, 2), round(path, 2)) == (45, 0.18, 0.54, 1.16)

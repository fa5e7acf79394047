"""Whether a run's coordination loop diverged, since when, and what to look at (issue 28).

A diverging run used to say only that its path-following error was OUTSIDE the tube and that its coordination error
never came below the tolerance, which a slow convergence says too. Diverged, here, is what a person reads off the
whole run (its coordination error starts wherever the vehicles start), cut into WINDOWS windows: the coordination
error's peak in the last window is the largest since its quiet windows (the last within FLOOR of the lowest peak),
at least GROWTH times the lowest and above the tolerance; and some path parameter's rate is further than v_r from
v_r at the end (running backwards, or at more than twice the reference: a fleet that only lags behind a fault stays
within that). Since: the end of the last quiet window, from which the error grew.

What to look at: the coordination loop's stability with the run's links (issue 23: `cpf stability`, which predicts
the error's growth rate and the transmit period, delay and loss the loop tolerates; docs/stability.md), and, when it
predicts convergence, the vehicles' inputs held at their limits (the summary's lines), which the linear analysis
does not see.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass

import numpy as np

from supervisor.analysis.summary import Series, coordination_error

WINDOWS = 20
GROWTH = 10.0
FLOOR = 2.0  # a window whose peak is within this factor of the lowest is still quiet


@dataclass(frozen=True, slots=True)
class Divergence:
    since: float  # s: the end of the last quiet window, from which the coordination error grew
    error_from: float  # the coordination error's peak in that window
    error_to: float  # its peak in the last window
    rate_off: float  # the largest |gamma_dot - v_r| in the last window
    path_error: float  # m, the largest |p - p_d| in the last window (nan: no vehicle alive)


def divergence(series: Series, v_r: float, tolerance: float) -> Divergence | None:
    """The run's divergence as the module docstring defines it, None if it did not diverge."""
    t = series.t
    edges = np.linspace(float(t[0]), float(t[-1]) + 1e-9, WINDOWS + 1)
    coord = coordination_error(series.gamma)
    windows = [(t >= a) & (t < b) for a, b in itertools.pairwise(edges)]
    peaks = np.array([_peak(coord[w]) for w in windows])
    if np.isnan(peaks).all() or np.isnan(peaks[-1]):
        return None
    # The last window still near the lowest peak: a steady error before the growth is one quiet stretch.
    lowest = float(np.nanmin(peaks))
    quiet = int(np.nonzero(peaks <= FLOOR * lowest)[0][-1])
    last = float(peaks[-1])
    still_growing = last >= float(np.nanmax(peaks[quiet:]))
    rate_off = _peak(np.abs(series.gamma_dot[windows[-1]] - v_r))
    if not (still_growing and last > tolerance and last >= GROWTH * lowest and rate_off > v_r):
        return None
    return Divergence(float(edges[quiet + 1]), lowest, last, rate_off, _peak(series.path_error[windows[-1]]))


def _peak(values: np.ndarray) -> float:
    known = values[~np.isnan(values)]
    return float(known.max()) if known.size else float("nan")


def format_divergence(
    found: Divergence, v_r: float, predicted: float | None, scenario_file: str, unmodelled: str | None = None
) -> str:
    """Two lines for the summary; predicted: the error's growth rate (1/s) the stability analysis predicts for the
    scenario (negative: it predicts convergence), None if it was not analysed; unmodelled: why the analysis does
    not model this loop (supervisor.config.links.unmodelled), if it does not."""
    path = "" if np.isnan(found.path_error) else f"; path-following error up to {found.path_error:.4g} m"
    head = (
        f"the coordination loop DIVERGED from about t = {found.since:.0f} s: its error grew from "
        f"{found.error_from:.3g} to {found.error_to:.3g}, the path parameters' rates up to {found.rate_off:.3g} "
        f"away from v_r = {v_r:g}{path}"
    )
    if unmodelled is not None:
        return f"{head}\nnot predicted: {unmodelled} (docs/stability.md)"
    look = f"look at: cpf stability {scenario_file} (docs/stability.md)"
    if predicted is None:
        return f"{head}\n{look}: whether the loop converges with these links, and what it tolerates"
    if predicted > 0:
        return (
            f"{head}\n{look}: it predicts this, the error growing at {predicted:.3g} 1/s with these links; it says "
            "which transmit period, delay and loss the loop would tolerate"
        )
    return (
        f"{head}\n{look}: it predicts convergence with these links (decay {-predicted:.3g} 1/s), so look at what "
        "it leaves out: the inputs at their limits above, the gains against the vehicle's speed"
    )


def as_metric(found: Divergence | None) -> dict[str, float] | None:
    """The verdict as the metrics hold it (cpf run --metrics, cpf report's metrics.json, the API's summary)."""
    return None if found is None else dataclasses.asdict(found)

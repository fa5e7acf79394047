"""Per-phase summary of a run: coordination error, path-following error, speed of the path parameters.

Phases are cut at fault starts and ends (for the paper: before the fault, during, after). Path-following errors are
counted only after the initial transient (scenario [report] transient).

A vehicle that is down (killed, lost) has no state: its entries in the series are NaN. Every statistic is over the
vehicles alive at each instant: the coordination error over the pairs alive (NaN while fewer than two are), the
path-following error over the vehicles alive, each vehicle's mean gamma_dot over the instants it was alive.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from itertools import pairwise

import numpy as np

from comms.records.records import FloatArray
from supervisor.analysis.condense import MAX_ROWS, spread

MAX_DECIMALS = 9  # of a phase's span: below a nanosecond two ends are float noise, not a phase


@dataclass(frozen=True, slots=True)
class Series:
    """Time series of a run: row k is time t[k], column i is vehicle vehicle_ids[i]; NaN where it has no state."""

    vehicle_ids: tuple[int, ...]
    t: FloatArray
    gamma: FloatArray
    gamma_dot: FloatArray
    path_error: FloatArray  # |p_i - p_d_i(gamma_i)|, m
    # The inputs the vehicles got, (steps, 3, vehicles): surge force [N], pitch and yaw torque [N m] (a planar
    # vehicle's pitch NaN), and their surge speed through the water [m/s]; None where the source has none.
    inputs: FloatArray | None = None
    surge: FloatArray | None = None


@dataclass(frozen=True, slots=True)
class PhaseStats:
    name: str
    start: float
    end: float
    max_coordination_error: float  # nan if fewer than two vehicles were alive throughout
    final_coordination_error: float  # at the phase's last instant with two vehicles alive
    max_path_error: float  # after the transient; nan if the phase lies inside it (or no vehicle was alive)
    mean_gamma_dot: tuple[float, ...]  # each over the instants the vehicle was alive; nan if it never was


@dataclass(frozen=True, slots=True)
class Summary:
    phases: tuple[PhaseStats, ...]
    tube_radius: float
    max_path_error_after_transient: float
    sync_time: float | None  # when the coordination error first stays below tolerance until the first phase ends
    resync_time: float | None  # the same, within the last phase
    tolerance: float
    transient: float = 0.0  # s: path-following errors count from then on
    last_state_time: float = math.nan  # s: the run's last instant with states (one step of the whole run: t = 0)

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


def coordination_error(gamma: FloatArray) -> FloatArray:
    """max_{i,j} |gamma_i - gamma_j| over the vehicles alive (gamma not NaN) at each time; NaN while fewer than two
    are alive (no pair to compare)."""
    alive = ~np.isnan(gamma)
    highest = np.where(alive, gamma, -np.inf).max(axis=1, initial=-np.inf)
    lowest = np.where(alive, gamma, np.inf).min(axis=1, initial=np.inf)
    result: FloatArray = np.where(alive.sum(axis=1) >= 2, highest - lowest, np.nan)
    return result


def nan_max(values: FloatArray) -> float:
    """The largest value that is not NaN; NaN if there is none (numpy's nanmax warns then)."""
    known = values[~np.isnan(values)]
    return float(known.max()) if known.size else math.nan


def nan_last(values: FloatArray) -> float:
    """The last value that is not NaN; NaN if there is none."""
    known = values[~np.isnan(values)]
    return float(known[-1]) if known.size else math.nan


def nan_mean_columns(values: FloatArray) -> tuple[float, ...]:
    """Each column's mean over its values that are not NaN; NaN for a column without any."""
    known = ~np.isnan(values)
    counts = known.sum(axis=0)
    sums = np.where(known, values, 0.0).sum(axis=0)
    return tuple(float(s / n) if n else math.nan for s, n in zip(sums, counts, strict=True))


def phase_bounds(duration: float, faults: Sequence[tuple[str, float, float]]) -> list[tuple[str, float, float]]:
    """(name, start, end) of each phase between fault boundaries (faults as (kind, start, end))."""
    cuts = sorted({b for _, s, e in faults for b in (s, e) if 0.0 < b < duration})
    edges = [0.0, *cuts, duration]
    phases = []
    for start, end in pairwise(edges):
        kinds = sorted({k for k, s, e in faults if s <= start and end <= e})
        if kinds:
            name = "during " + "+".join(kinds)
        else:
            name = "before faults" if start == 0.0 and cuts else ("after faults" if cuts else "whole run")
        phases.append((name, start, end))
    return phases


def settle_time(t: FloatArray, error: FloatArray, tolerance: float) -> float | None:
    """First time after which error stays below tolerance to the end of the given window; None if never."""
    above = np.nonzero(error >= tolerance)[0]
    if len(above) == 0:
        return float(t[0])
    last = above[-1]
    return float(t[last + 1]) if last + 1 < len(t) else None


def phases_end(t: FloatArray, step: float, duration: float) -> float:
    """Where a run's phases end: its duration, or one step past the last state of a run stopped early (Ctrl-C, a
    vehicle lost: its last phase ended at the scenario's 2000 s with the data at 243 s, a new user's study)."""
    last = float(t[-1]) + step if t.size else duration
    return last if last < duration - step / 2 else duration


def summarize(
    series: Series,
    duration: float,
    faults: Sequence[tuple[str, float, float]],
    transient: float,
    tube_radius: float,
    tolerance: float,
) -> Summary:
    coord = coordination_error(series.gamma)
    # Phase bounds lie on the step grid (derived.intervals) as a person writes them (0.9), the series' times as
    # k dt computes them (3 x 0.3 = 0.8999999999999999): half a step either way puts each step on its side.
    half = 0.5 * float(series.t[1] - series.t[0]) if series.t.size > 1 else 0.0
    stats = []
    for name, start, end in phase_bounds(duration, faults):
        mask = (series.t >= start - half) & (series.t < end - half)
        if not mask.any():
            continue
        settled = mask & (series.t >= transient)
        stats.append(
            PhaseStats(
                name, start, end, nan_max(coord[mask]), nan_last(coord[mask]),
                nan_max(series.path_error[settled]), nan_mean_columns(series.gamma_dot[mask]),
            )
        )  # fmt: skip
    first, last = stats[0], stats[-1]
    in_first = series.t < first.end - half
    in_last = series.t >= last.start - half
    after = series.t >= transient
    return Summary(
        phases=tuple(stats),
        tube_radius=tube_radius,
        max_path_error_after_transient=nan_max(series.path_error[after]),
        sync_time=settle_time(series.t[in_first], coord[in_first], tolerance),
        resync_time=settle_time(series.t[in_last], coord[in_last], tolerance) if len(stats) > 1 else None,
        tolerance=tolerance,
        transient=transient,
        last_state_time=float(series.t[-1]),
    )


def format_summary(summary: Summary) -> str:
    """A plain-text table for the terminal. Its path-error column (*) leaves out the transient: the line under the
    table, marked * too, says from when it counts (a run without faults has one row, "whole run", that a
    researcher read as the whole run's)."""
    lines = [
        f"{'phase':<22}{'span [s]':>14}{'max|gi-gj|':>12}{'end|gi-gj|':>12}{'max|p-pd| [m]*':>16}  mean gamma_dot",
    ]
    for p in summary.phases:
        span = _span(p.start, p.end)
        rates = " ".join(_number(v, ".3f", 9) for v in p.mean_gamma_dot)  # "-": the vehicle was down all the phase
        if len(p.mean_gamma_dot) > MAX_ROWS:
            rates = spread(p.mean_gamma_dot, ".3f")
        path = _number(p.max_path_error, ".3f", 14)  # "-": within the transient
        lines.append(
            f"{p.name:<22}{span:>14}{_number(p.max_coordination_error, '.4g', 11):>12}"
            f"{_number(p.final_coordination_error, '.3g', 11):>12}{path:>16}  {rates}"
        )
    worst = summary.max_path_error_after_transient
    after = f"* path-following error after the transient (from t = {summary.transient:g} s)"  # the column's *
    if math.isnan(worst):  # nothing to judge
        lines.append(f"{after}: none ({_why_none(summary)}); tube {summary.tube_radius:.3f} m")
    else:
        tube_ok = worst <= summary.tube_radius
        lines.append(
            f"{after}: max {worst:.3f} m, tube {summary.tube_radius:.3f} m ({'inside' if tube_ok else 'OUTSIDE'})"
        )
    lines.append(_settled("", summary.sync_time, summary.tolerance, "first phase"))
    if summary.resync_time is not None or len(summary.phases) > 1:
        lines.append(_settled(" again", summary.resync_time, summary.tolerance, "last phase"))
    return "\n".join(lines)


def _why_none(summary: Summary) -> str:
    """Why no path-following error counts: the run ends within the transient, no state lies after it (a step as long
    as the run: "no vehicle was alive" said of vehicles alive throughout, a new user), or all were down then."""
    if not summary.phases or summary.phases[-1].end <= summary.transient:
        return "the run ends within it"
    if not summary.last_state_time >= summary.transient:
        return f"no state lies after it: the last is at t = {summary.last_state_time:g} s"
    return "no vehicle was alive after it"


def _span(start: float, end: float) -> str:
    """'start-end' in whole seconds ("0-150"), or with the fewest decimals that tell the two ends apart and put each
    within a tenth of the span of its value, trailing zeros left out ("10-10.1", "10-10.05", not "10-10.1" for the
    latter): whole seconds alone printed a one-step phase as "10-10" (a new user)."""
    tolerance = (end - start) / 10
    decimals = next((d for d in range(MAX_DECIMALS) if _tells(start, end, d, tolerance)), MAX_DECIMALS)
    return f"{_decimal(start, decimals)}-{_decimal(end, decimals)}"


def _tells(start: float, end: float, decimals: int, tolerance: float) -> bool:
    first, last = f"{start:.{decimals}f}", f"{end:.{decimals}f}"
    return first != last and abs(float(first) - start) <= tolerance and abs(float(last) - end) <= tolerance


def _decimal(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    return text.rstrip("0").rstrip(".") if decimals else text


def _settled(again: str, time: float | None, tolerance: float, phase: str) -> str:
    if time is None:
        return f"coordination error never below {tolerance:g} to the end of the {phase}"
    return f"coordination error below {tolerance:g}{again} from t = {time:.1f} s ({phase})"


def _number(value: float, spec: str, width: int) -> str:
    """value formatted, or "-" for NaN (nothing to say: no vehicle, or no pair of vehicles, alive); in three
    significant digits where spec would be wider than its column (1e30 with 3 decimals: the columns stay aligned)."""
    if math.isnan(value):
        return "-"
    text = format(value, spec)
    return text if len(text) <= width else format(value, ".3g")

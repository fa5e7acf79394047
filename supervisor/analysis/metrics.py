"""The numbers of a recorded run, as one JSON-able dict (`run_metrics`), written by the report as metrics.json.

Definitions (t: simulation time of the recorded vehicle states, s):

- coordination error: max_{i,j} |gamma_i - gamma_j| at each recorded step (analysis.summary.coordination_error)
  over the vehicles alive then (a vehicle that is down has no state); none while fewer than two are alive. Every
  statistic below is, like `cpf run`'s summary, over the vehicles alive at each instant.
- phases: analysis.summary.phase_bounds over the scenario's duration, cut at the starts and ends of the scenario's
  faults (from the log's meta: the validated scenario, --fault included; open ends closed at the end of the run).
  settings.faults holds each with every field the scenario gives it, its end so closed.
  Per phase: peak and final coordination error, peak path-following error after the transient, mean gamma_dot.
- convergence time: the first time after which the coordination error stays below report.coordination_tolerance
  until the first fault starts (the end of the run without faults); reconvergence time: the same within the last
  phase (after the last fault ends, or while the last one acts if it never ends), as the summary's "below ...
  again from" line has it (analysis.summary.Summary.resync_time); None without faults. None: never below to the end.
- steady-state coordination error: the largest coordination error over the final STEADY_STATE_WINDOW = 50 s of the
  recorded states after report.transient, [max(t_end - 50 s, transient), t_end], whatever faults act then (NaN for
  a run that ends within its transient).
- path following: the largest |p - p_d| after report.transient, the tube radius |delta| + report.tube_margin, and
  whether it stayed inside (None: no state after the transient).
- gamma_dot at the end: each vehicle's last recorded gamma_dot.
- packets: counted from the link events of the log (cpf/comms/events), which cover the whole run whichever broker
  process emitted them (the broker's own stats restart with a restarted broker): per directed link and in total,
  sent, delivered, dropped, dropped by cause, still in flight (sent - delivered - dropped: 0 in a complete log), and
  the delivery delays.
- estimate age: per (neighbour -> holder), the mean and largest age of the holder's estimate of the neighbour.
- lambda_2: of the delivered graph over the broker's stats windows (min, mean, windows at 0 = disconnected); the
  graph of a window holds the pairs that delivered within the last `horizon` s (the window, or 1.5 transmit
  intervals if the vehicles' schedule leaves longer between packets: supervisor.config.fleet.delivered_graph_horizon).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from dataclasses import asdict
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from comms.broker.stats import clamp_lambda2
from comms.records.records import FloatArray
from comms.records.reports import CommsStats
from supervisor.analysis.divergence import as_metric, divergence
from supervisor.analysis.summary import (
    PhaseStats,
    Series,
    Summary,
    coordination_error,
    nan_max,
    phases_end,
    summarize,
)
from supervisor.config.derived import intervals
from supervisor.config.scenario import validate_data
from supervisor.config.scenario_schema import ReportSection, Scenario
from supervisor.errors import ScenarioError

if TYPE_CHECKING:
    from pathlib import Path

    from supervisor.analysis.rundata import LinkLog, RunData
    from supervisor.analysis.tx_books import BooksLog

__all__ = [
    "STEADY_STATE_WINDOW",
    "Settings",
    "packet_counts",
    "report_metrics",
    "run_metrics",
    "run_series",
    "run_settings",
]

STEADY_STATE_WINDOW = 50.0  # s at the end of the run


class Settings(NamedTuple):
    """What the metrics need of the scenario."""

    duration: float
    faults: list[tuple[str, float, float]]  # (kind, start, end), end closed at the end of the run
    transient: float
    tube_radius: float
    tolerance: float


def report_metrics(log: Path, run: RunData, books: BooksLog) -> dict[str, Any]:
    """What metrics.json (`cpf report`) and the API's Run.summary hold: every metric of the run (run_metrics), the
    transmissions per link (tx = sent + not_sent: analysis.tx_books, books read from the log in the same pass as run)
    and what the log is drawn from if it is not a run as it ran (None: it is; supervisor.record.provenance)."""
    from supervisor.analysis.tx_books import books_of
    from supervisor.record.provenance import drawn_from

    numbers = run_metrics(run)
    numbers["transmissions"] = {f"{i}->{j}": book.as_dict() for (i, j), book in books_of(books).items()}
    numbers["drawn_from"] = drawn_from(log)
    return numbers


def run_metrics(run: RunData) -> dict[str, Any]:
    """Every metric of the run (see the module docstring); non-finite numbers become None."""
    scenario = run_scenario(run)
    settings = run_settings(run, scenario)
    metrics: dict[str, Any] = {
        "run": _run_info(run),
        "settings": {
            **settings._asdict(),
            "faults": _fault_settings(run, scenario, settings),
            "steady_state_window": STEADY_STATE_WINDOW,
        },
        "packets": packet_counts(run.links.values()),
        "estimate_age": _ages(run),
        "lambda2": _lambda2(run),
        # reader -> key (cause) -> messages it dropped, as cpf run --metrics has them (none in process: no bus)
        "malformed": run.drops.by_key,
        "dropped_by_cause": run.drops.by_cause,
    }
    series = run_series(run)
    if series.t.size:
        end = phases_end(series.t, run.meta.step if run.meta is not None else 0.0, settings.duration)
        summary = summarize(series, end, settings.faults, settings.transient, settings.tube_radius, settings.tolerance)
        metrics |= _coordination(series, summary)
        if scenario is not None:  # the time each vehicle sat at its [saturation] top_speed
            from supervisor.analysis.input_limits import at_input_limits, input_limits_metrics
            from supervisor.analysis.saturation_summary import at_limit, limits_metrics

            metrics |= limits_metrics(at_limit(scenario, series))
            metrics |= input_limits_metrics(at_input_limits(scenario, series))
            found = divergence(series, scenario.coordination.v_r, settings.tolerance)
            metrics["divergence"] = as_metric(found)  # as cpf run --metrics has it
    metrics |= _navigation(run, settings.transient)
    return finite(metrics)


def run_scenario(run: RunData) -> Scenario | None:
    """The scenario the run's meta holds, validated; None for a log cut before its meta, an older or a synthetic one."""
    if run.meta is None:
        return None
    try:
        return validate_data(run.meta.scenario, "meta")
    except ScenarioError:
        return None


def _navigation(run: RunData, transient: float) -> dict[str, Any]:
    """Per vehicle with navigation: |p_hat - p| after the transient (mean, max, last) and the fixes fused and lost
    over the run (vehicles.navigation codes 1 and 2); {} for a run whose controllers saw the truth."""
    out = {}
    for vid, s in run.vehicles.items():
        if s.nav_error is None or s.nav_fix is None:
            continue
        after = s.nav_error[s.t >= transient]
        out[str(vid)] = {
            "mean_error": float(after.mean()) if after.size else None,
            "max_error": float(after.max()) if after.size else None,
            "last_error": float(s.nav_error[-1]) if s.nav_error.size else None,
            "fixes_fused": int((s.nav_fix == 1).sum()),
            "fixes_lost": int((s.nav_fix == 2).sum()),
        }
    return {"navigation": out} if out else {}


def run_settings(run: RunData, scenario: Scenario | None) -> Settings:
    """Duration, faults and [report] settings: from the scenario (the meta's, validated: _scenario), else from the
    meta's fields."""
    meta = run.meta
    if meta is None:  # a log cut before its meta: what its states say
        rep = ReportSection()
        return Settings(run.t_range[1], [], rep.transient, math.nan, rep.coordination_tolerance)
    duration, tube = meta.duration, meta.tube_radius
    if scenario is None:  # an older log, or a synthetic one: the meta's own fields
        rep = ReportSection()
        faults = [(str(f["kind"]), float(f["start"]), _end(f.get("end"), duration)) for f in meta.faults]
        return Settings(duration, faults, rep.transient, tube, rep.coordination_tolerance)
    rep = scenario.report
    return Settings(duration, intervals(scenario), rep.transient, tube, rep.coordination_tolerance)


def _fault_settings(run: RunData, scenario: Scenario | None, settings: Settings) -> list[dict[str, Any]]:
    """Each fault with every field the scenario gives it (its target, its parameters), its end as the phases take it
    (settings.faults: closed at the end of the run, a broker restarted a step after its kill unless told)."""
    if scenario is not None:
        fields = [f.model_dump(mode="json") for f in scenario.faults]
    else:  # an older or a synthetic log: the meta's record of them
        fields = [dict(f) for f in run.meta.faults] if run.meta is not None else []
    return [{**f, "start": start, "end": end} for f, (_, start, end) in zip(fields, settings.faults, strict=False)]


def _end(end: Any, duration: float) -> float:
    return duration if end is None else min(float(end), duration)


def run_series(run: RunData) -> Series:
    """The vehicles' states on one time grid (by sync step), NaN where a vehicle has none, for analysis.summary."""
    ids = tuple(run.vehicles)
    if not ids:
        return Series((), np.empty(0), np.empty((0, 0)), np.empty((0, 0)), np.empty((0, 0)))
    step = 0.0 if run.meta is None else run.meta.step
    keys = {v: _step_index(s.t, step) for v, s in run.vehicles.items()}
    grid = np.unique(np.concatenate(list(keys.values())))
    columns = [np.full((grid.size, len(ids)), np.nan) for _ in range(3)]
    inputs, surge = np.full((grid.size, 3, len(ids)), np.nan), np.full((grid.size, len(ids)), np.nan)
    for col, (vid, series) in enumerate(run.vehicles.items()):
        rows = np.searchsorted(grid, keys[vid])
        for out, values in zip(columns, (series.gamma, series.gamma_dot, series.error_norm), strict=True):
            out[rows, col] = values
        tau = series.tau  # (n, 3), or a planar vehicle's (n, 2): surge and yaw
        if tau.shape[1] in (2, 3):
            inputs[rows, :, col] = (
                tau if tau.shape[1] == 3 else np.column_stack((tau[:, 0], tau[:, 0] * np.nan, tau[:, 1]))
            )
        surge[rows, col] = series.velocity[:, 0]
    t = grid * step if step > 0 else grid
    gamma, gamma_dot, path_error = columns
    return Series(ids, t.astype(float), gamma, gamma_dot, path_error, inputs, surge)


def _step_index(t: np.ndarray, step: float) -> np.ndarray:
    """Sync-step numbers of the times (the times themselves without a step)."""
    return np.rint(t / step).astype(np.int64) if step > 0 else t


def steady_error(t: FloatArray, coord: FloatArray, transient: float) -> tuple[float, list[float]]:
    """The steady-state coordination error and its window [from, to] s, of the coordination error coord at times t:
    the largest over the final STEADY_STATE_WINDOW s of the run that lie after the transient; NaN if none does (a run
    shorter than its transient and the window: its "steady" error had been its transient's, above the peak after it;
    a new user)."""
    end = float(t[-1])
    start = max(end - STEADY_STATE_WINDOW, transient, float(t[0]))
    final = t >= start
    return nan_max(coord[final]) if final.any() else math.nan, [min(start, end), end]


def _coordination(series: Series, summary: Summary) -> dict[str, Any]:
    worst = summary.max_path_error_after_transient
    steady, window = steady_error(series.t, coordination_error(series.gamma), summary.transient)
    return {
        "coordination": {
            "tolerance": summary.tolerance,
            "convergence_time": summary.sync_time,
            "reconvergence_time": summary.resync_time,
            "steady_state_error": steady,
            "steady_state_window": window,
            "phases": [_phase(p, series.vehicle_ids) for p in summary.phases],
        },
        "path_following": {
            "max_error_after_transient": summary.max_path_error_after_transient,
            "tube_radius": summary.tube_radius,
            "inside_tube": None if math.isnan(worst) else bool(worst <= summary.tube_radius),
        },
        "gamma_dot_end": {str(v): _last(series.gamma_dot[:, k]) for k, v in enumerate(series.vehicle_ids)},
    }


def _phase(phase: PhaseStats, ids: tuple[int, ...]) -> dict[str, Any]:
    out = asdict(phase)
    out["mean_gamma_dot"] = {str(v): rate for v, rate in zip(ids, phase.mean_gamma_dot, strict=True)}
    return out


def _last(values: np.ndarray) -> float | None:
    """The last recorded (non-NaN) value."""
    finite = values[~np.isnan(values)]
    return float(finite[-1]) if finite.size else None


def packet_counts(links: Iterable[LinkLog]) -> dict[str, Any]:
    """Per directed link ('1->2') and in total: sent, delivered, dropped (by cause), in flight, delays."""
    per_link = {link.name: _link_counts(link) for link in links}
    total_causes: Counter[str] = Counter()
    for counts in per_link.values():
        total_causes.update(counts["dropped_by_cause"])
    total = {k: sum(c[k] for c in per_link.values()) for k in ("sent", "delivered", "dropped", "in_flight")}
    return {"links": per_link, "total": {**total, "dropped_by_cause": dict(sorted(total_causes.items()))}}


def _link_counts(link: LinkLog) -> dict[str, Any]:
    sent, delivered = int((link.kind == "sent").sum()), int((link.kind == "delivered").sum())
    dropped = int((link.kind == "dropped").sum())
    delays = link.delays
    return {
        "sent": sent,
        "delivered": delivered,
        "dropped": dropped,
        "dropped_by_cause": link.dropped_by_cause(),
        "in_flight": sent - delivered - dropped,
        "delay_min": float(delays.min()) if delays.size else None,
        "delay_mean": float(delays.mean()) if delays.size else None,
        "delay_max": float(delays.max()) if delays.size else None,
    }


def _ages(run: RunData) -> dict[str, Any]:
    return {
        f"{neighbour}->{holder}": {"mean": float(a.age.mean()), "max": float(a.age.max()), "samples": int(a.age.size)}
        for (neighbour, holder), a in run.estimate_ages.items()
        if a.age.size
    }


def _lambda2(run: RunData) -> dict[str, Any]:
    values = np.array([clamp_lambda2(s.lambda2) for s in run.stats])  # an older log: -1e-17 for 0
    if not values.size:
        return {"windows": 0, "min": None, "mean": None, "max": None, "disconnected_windows": 0, "horizon": None}
    return {
        "windows": int(values.size),
        "min": float(values.min()),
        "mean": float(values.mean()),
        "max": float(values.max()),
        "disconnected_windows": int((values <= 0.0).sum()),
        "horizon": _horizon(run.stats[-1]),
    }


def _horizon(snapshot: CommsStats) -> float:
    """Over how long the snapshot's delivered graph is taken: its window, unless it says (an older log does not)."""
    return snapshot.window if snapshot.horizon is None else snapshot.horizon


def _run_info(run: RunData) -> dict[str, Any]:
    meta = run.meta
    start, end = run.t_range
    keys = ("scenario_name", "scenario_file", "engine", "clock", "seed", "step", "duration")
    known = {k: None if meta is None else getattr(meta, k) for k in keys}
    return {**known, "vehicles": list(run.vehicles), "t_first": start, "t_last": end}


def finite(value: Any) -> Any:
    """The value with every NaN or infinity replaced by None (strict JSON has neither)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite(v) for v in value]
    return value

"""Summary plots of a sweep: steady-state coordination error, time back below tolerance after the last fault (or,
without faults, below it to stay from the start) and packets against each swept parameter, the line the median
across seeds and the band the 10-90 % spread.

A parameter given a single value is not swept: it gets no plot of its own, and the plots of the others name it in
their title. Every other combination of the other parameters is one line per panel. A log axis always spans at
least a decade (values closer than that would get a row of identical tick labels); the parameter axis is
logarithmic when its values are positive and span at least LOG_X_DECADES decades. Values that are not numbers
(graphs, names) are placed evenly and labelled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import NDArray

from supervisor.analysis.figures import distinct_colours, save
from supervisor.analysis.legends import place_legend
from supervisor.analysis.metrics import STEADY_STATE_WINDOW
from supervisor.tools.sweep_params import Param

FLOOR = 1e-6  # log axes: errors below this are drawn at it
LOG_X_DECADES = 2


def plot_sweep(rows: Sequence[dict[str, Any]], params: Sequence[Param], out_dir: Path) -> list[Path]:
    """One PNG per parameter swept over two or more values; returns their paths (none if nothing was swept)."""
    swept = [p for p in params if len(p.values) > 1]
    fixed = ", ".join(f"{p.key}={p.values[0]}" for p in params if len(p.values) == 1)
    paths = []
    for param in swept:
        fig = _figure(rows, param, [p for p in swept if p.key != param.key], fixed)
        paths.append(save(fig, out_dir / f"sweep_{param.key.replace('.', '_')}.png"))
    return paths


def _figure(rows: Sequence[dict[str, Any]], param: Param, others: list[Param], fixed: str) -> Figure:
    fig = Figure(figsize=(17, 5), layout="constrained")
    error_ax, resync_ax, packet_ax = fig.subplots(1, 3)
    combos = list(product(*[[(p.key, v) for v in p.values] for p in others]))
    column, what, title = _settling(rows)
    for combo, c in zip(combos, distinct_colours(len(combos)), strict=True):
        chosen = [r for r in rows if all(r.get(k) == v for k, v in combo)]
        label = ", ".join(f"{k.split('.')[-1]}={v}" for k, v in combo)
        _band(error_ax, chosen, param, "steady_coordination_error", label or "steady state", c, log=True)
        _band(resync_ax, chosen, param, column, label or what, c)
        _band(packet_ax, chosen, param, "sent", f"sent {label}".strip(), c)
        _band(packet_ax, chosen, param, "delivered", f"delivered {label}".strip(), c, dashed=True)
    seeds = len({r["seed"] for r in rows})
    error_ax.set_yscale("log")
    error_ax.set_ylabel(f"max|gamma_i - gamma_j|, final {STEADY_STATE_WINDOW:.0f} s")
    spread = f"{seeds} seeds: median, 10-90 %" if seeds > 1 else "1 seed"  # one seed has no spread to show
    error_ax.set_title(f"Steady-state coordination error ({spread})")
    resync_ax.set_ylabel("s (never: not drawn)")
    resync_ax.set_title(title)
    packet_ax.set_ylabel("packets (all directed links)")
    packet_ax.set_title("Packets sent (solid) and delivered (dashed)")
    for ax in (error_ax, resync_ax, packet_ax):
        _finish(ax, param)
    if fixed:
        fig.suptitle(f"fixed: {fixed}")
    return fig


def _settling(rows: Sequence[dict[str, Any]]) -> tuple[str, str, str]:
    """The column of the middle panel, its line's label and its title: when the coordination error came back below
    the tolerance after the last fault (resync_time), or, when no run has one (no fault: every phase is the first),
    when it first came below it to stay (sync_time)."""
    if any(r.get("resync_time") is not None for r in rows):
        return "resync_time", "after the last fault", "Coordination back below tolerance at"
    return "sync_time", "from the start", "Coordination below tolerance (to stay) at"


def _finish(ax: Axes, param: Param) -> None:
    """Parameter axis, grid, legend; a panel without data says so (an empty legend would warn)."""
    ax.set_xlabel(param.key)
    ax.grid(True, alpha=0.3)
    if not ax.lines:
        ax.text(0.5, 0.5, "no run has a value", transform=ax.transAxes, ha="center", va="center", color="0.4")
        ax.set_xlim(0, len(param.values) - 1)
        if _numeric(param.values):
            ax.set_xlim(min(param.values), max(param.values))
    if not _numeric(param.values):
        ax.set_xticks(range(len(param.values)), [_short(v) for v in param.values], rotation=20, ha="right")
    elif _log_x(param.values):
        ax.set_xscale("log")
    for axis in ("x", "y"):
        _at_least_a_decade(ax, axis)
    place_legend(ax, fontsize="x-small")


def _band(
    ax: Axes,
    rows: Sequence[dict[str, Any]],
    param: Param,
    column: str,
    label: str,
    colour: Any,
    log: bool = False,
    dashed: bool = False,
) -> None:
    """Median line and 10-90 % band of one column against the parameter, over the runs that have a value."""
    # A run that never got there (None) has no value to draw; the band shows the runs that did.
    points = [(x, _values(rows, param.key, value, column)) for x, value in _positions(param)]
    points = [(x, v) for x, v in points if v.size]
    if not points:
        return
    xs = [x for x, _ in points]
    values = [np.maximum(v, FLOOR) if log else v for _, v in points]
    median = [float(np.median(v)) for v in values]
    low = [float(np.percentile(v, 10)) for v in values]
    high = [float(np.percentile(v, 90)) for v in values]
    ax.plot(xs, median, marker="s" if dashed else "o", ls="--" if dashed else "-", color=colour, label=label)
    ax.fill_between(xs, low, high, color=colour, alpha=0.15)


def _positions(param: Param) -> list[tuple[float, Any]]:
    """(where on the axis, value) per value: the value itself if every value is a number, else its index."""
    if _numeric(param.values):
        return [(float(v), v) for v in param.values]
    return [(float(k), v) for k, v in enumerate(param.values)]


def _values(rows: Sequence[dict[str, Any]], key: str, value: Any, column: str) -> NDArray[np.float64]:
    values = np.array([float(r[column]) for r in rows if r.get(key) == value and r.get(column) is not None])
    return values[~np.isnan(values)]  # NaN: none to draw (a steady error of a run that ends within its transient)


def _numeric(values: Sequence[Any]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _log_x(values: Sequence[Any]) -> bool:
    low, high = min(values), max(values)
    return bool(low > 0 and high / low >= 10.0**LOG_X_DECADES)


def _short(value: Any, width: int = 24) -> str:
    text = str(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def _at_least_a_decade(ax: Axes, axis: str) -> None:
    """Widen a log axis to a decade around the geometric middle of its data: over less, matplotlib labels the
    minor ticks with more digits than it shows, and a row of identical labels (5.26056x10^0 ...) results."""
    scale = ax.get_yscale() if axis == "y" else ax.get_xscale()
    limits = ax.dataLim.intervaly if axis == "y" else ax.dataLim.intervalx
    low, high = float(min(limits)), float(max(limits))
    if scale != "log" or not (math.isfinite(low) and math.isfinite(high)) or low <= 0 or high / low >= 10.0:
        return
    middle = math.sqrt(low * high)
    span = (middle / math.sqrt(10.0), middle * math.sqrt(10.0))
    if axis == "y":
        ax.set_ylim(*span)
    else:
        ax.set_xlim(*span)

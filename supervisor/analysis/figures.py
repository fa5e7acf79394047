"""The paper's figures of a recorded run (Figs. 3-8 of Aguiar & Pascoal, "Coordinated path-following control of
multiple AUVs") and the helpers every run figure shares, drawn so that a reader can follow them at any fleet size.

Rules that decide what is drawn (each chosen by the data, never by the scenario's name):

- Colours: one per vehicle, the same vehicle in the same colour in every figure; tab10 up to 10 vehicles, tab20 up
  to 20, evenly spaced hues of a continuous colormap beyond, so no two vehicles share a colour.
- Legends (supervisor.analysis.legends): up to LEGEND_INSIDE_MAX entries inside the axes where they hide least; more
  go beside the axes, in columns of at most LEGEND_ROWS_MAX, and constrained layout keeps them within the saved
  image. More than LEGEND_VEHICLES_MAX vehicles (lines marked with gid VEHICLE): a colour bar from hue to vehicle
  replaces their entries (1000 entries did not fit any image), the other entries stay in the legend.
- Coordination errors (Fig. 5): up to PAIRWISE_MAX_VEHICLES vehicles, gamma_i - gamma_j for every pair as in the
  paper; more vehicles, each vehicle's gamma_i minus the mean gamma of the vehicles alive at that instant (NaN where
  a vehicle is down), with the fleet's spread max gamma - min gamma, the coordination error of the summary. The
  scale comes from the data's range: its peak against its steady level (the 10th percentile of the largest error
  at each instant over the second half of the run, or over its last tenth if lower; zeros left out).
  SYMLOG_DECADES decades or more apart: symlog, linear only within the decade below the steady level, so the
  steady-state error shows in decades beside the transient; closer: linear, on which both show. The axis label says
  which (and the linear band).
- Trajectories (Fig. 3): a planar run (scenario dimension 2), or one whose depth span is at most FLAT_RATIO of its
  horizontal span, is drawn top-down (x-y) only, with equal axes: a 3-D view would blow 0.2 m of depth up into
  dives. Any other run gets the 3-D view with equal scaling on all three axes beside the top-down view.

Figures are built on ``matplotlib.figure.Figure`` directly (Agg canvas, no pyplot): no global plotting state.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import NDArray

from supervisor.analysis.legends import LEGEND_VEHICLES_MAX, VEHICLE, colour_key, place_legend
from supervisor.analysis.panels import panel_grid
from supervisor.config.derived import gamma_unit, rate_label

if TYPE_CHECKING:  # only for annotations: supervisor.analysis.report imports this module
    from pathlib import Path

    from supervisor.analysis.rundata import FaultInterval, RunData, VehicleSeries

__all__ = [
    "DPI",
    "FLAT_RATIO",
    "PAIRWISE_MAX_VEHICLES",
    "aligned",
    "colour",
    "distinct_colours",
    "fig_coordination_errors",
    "fig_gamma_dot",
    "fig_path_following_errors",
    "fig_trajectories",
    "fig_velocities",
    "finish_time_axes",
    "is_flat",
    "new_figure",
    "save",
    "vehicle_colours",
]

Array = NDArray[np.float64]

DPI = 120
FAULT_COLOUR = "tab:red"
FAULT_ALPHA = 0.15
FAULT_HATCHES = ("", "//", "\\\\", "xx", "..")  # tells distinct fault labels apart under one colour
SYMLOG_DECADES = 2  # coordination errors are drawn symlog only if their peak is this many decades above their level
PAIRWISE_MAX_VEHICLES = 4  # 6 pairs: the paper's Fig. 5 shows 3; at 5 vehicles there would be 10 lines
FLAT_RATIO = 0.1  # depth span / horizontal span at or below which the trajectories are drawn top-down only
TIME_DECIMALS = 9  # time stamps of different vehicles are matched after rounding to 1 ns


# --- shared helpers ----------------------------------------------------------------------------------------


def save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)  # explicit Agg canvas: no dependency on the configured backend
    fig.savefig(path, dpi=DPI)
    return path


def new_figure(width: float = 9.0, height: float = 5.0) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def colour(index: int) -> str:
    return f"C{index % 10}"


def distinct_colours(n: int) -> list[Any]:
    """n colours, no two alike: tab10, tab20, then evenly spaced hues of turbo (its ends are too dark/light)."""
    if n <= 10:
        return [colormaps["tab10"](k) for k in range(n)]
    if n <= 20:
        return [colormaps["tab20"](k) for k in range(n)]
    return [colormaps["turbo"](x) for x in np.linspace(0.05, 0.95, n)]


def _shade_faults(ax: Axes, faults: Sequence[FaultInterval]) -> None:
    """Light red band per fault interval; each distinct label enters the legend once."""
    labels = list(dict.fromkeys(f.label for f in faults))
    hatches = {label: FAULT_HATCHES[k % len(FAULT_HATCHES)] for k, label in enumerate(labels)}
    seen: set[str] = set()
    for fault in faults:
        label = fault.label if fault.label not in seen else "_nolegend_"
        seen.add(fault.label)
        ax.axvspan(
            fault.start, fault.end, color=FAULT_COLOUR, alpha=FAULT_ALPHA, hatch=hatches[fault.label], label=label
        )


def finish_time_axes(ax: Axes, run: RunData, ylabel: str, title: str | None = None) -> None:
    """Decorate a time-axis plot: fault bands, labels, grid and (if anything is labelled) a legend."""
    _shade_faults(ax, run.faults)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    start, end = run.t_range
    if end > start:
        ax.set_xlim(start, end)
    place_legend(ax)


def vehicle_colours(run: RunData) -> dict[int, Any]:
    return dict(zip(run.vehicles, distinct_colours(len(run.vehicles)), strict=True))


# --- Fig. 3: trajectories --------------------------------------------------------------------------------------


def _planar(run: RunData) -> bool:
    """Whether the run's scenario (as its meta records it) is planar."""
    return run.meta is not None and run.meta.scenario.get("scenario", {}).get("dimension") == 2


def is_flat(run: RunData) -> bool:
    """Whether the run is best seen from above: planar, or its depth span at most FLAT_RATIO of the horizontal."""
    if _planar(run):
        return True
    points = _all_points(run)
    if not len(points):
        return True
    span = np.ptp(points, axis=0)
    return bool(span[2] <= FLAT_RATIO * max(span[0], span[1]))


def _all_points(run: RunData) -> Array:
    """Every recorded vehicle and desired position, finite rows only, shape (n, 3)."""
    rows = [p for s in run.vehicles.values() for p in (s.position, s.desired)]
    points = np.concatenate(rows) if rows else np.empty((0, 3))
    return points[np.isfinite(points).all(axis=1)]


def fig_trajectories(run: RunData) -> Figure:
    """Fig. 3: actual (solid) and desired (dashed) trajectories, start and end marked; top-down for flat runs,
    else 3-D at equal scale beside the top-down view."""
    flat = is_flat(run)
    fig = new_figure(9.0, 7.5) if flat else new_figure(15.0, 7.0)
    if not flat:  # constrained layout does not see the 3-D axes' z label: keep it off the top-down view's y label
        fig.set_layout_engine("constrained", wspace=0.12)
    colours = vehicle_colours(run)
    if not flat:
        _draw_3d(fig.add_subplot(1, 2, 1, projection="3d"), run, colours)
    top = fig.add_subplot(1, 1, 1) if flat else fig.add_subplot(1, 2, 2)
    _draw_top_down(top, run, colours, _depth_note(run) if flat else "")
    fig.suptitle(f"Coordinated path-following: {run.name}")
    handles = [Line2D([], [], color=colours[v], lw=1.6, label=f"AUV {v}") for v in run.vehicles]
    if len(handles) > LEGEND_VEHICLES_MAX:
        colour_key(top, list(colours.values()), [f"AUV {v}" for v in run.vehicles], fig)
        handles = []
    handles += _style_key()
    fig.legend(handles=handles, loc="outside right upper", fontsize="small", ncols=math.ceil(len(handles) / 20))
    return fig


def _style_key() -> list[Line2D]:
    """What the line styles and markers mean (in black: they apply to every vehicle)."""
    return [
        Line2D([], [], color="k", lw=1.6, label="vehicle"),
        Line2D([], [], color="k", lw=1.0, ls="--", label="desired path"),
        Line2D([], [], color="k", ls="", marker="o", label="vehicle start"),
        Line2D([], [], color="k", ls="", marker="x", label="path start"),
        Line2D([], [], color="k", ls="", marker="s", label="vehicle end"),
    ]


def _draw_top_down(ax: Axes, run: RunData, colours: dict[int, Any], note: str) -> None:
    for vehicle, series in run.vehicles.items():
        c, p, pd = colours[vehicle], series.position, series.desired
        ax.plot(pd[:, 0], pd[:, 1], color=c, lw=1.0, ls="--")
        ax.plot(p[:, 0], p[:, 1], color=c, lw=1.6)
        if len(p):
            ax.plot(*p[0, :2], color=c, marker="o", ls="")
            ax.plot(*pd[0, :2], color=c, marker="x", ls="")
            ax.plot(*p[-1, :2], color=c, marker="s", ls="")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"Top-down (x-y), equal axes{note}", fontsize="medium")


def _depth_note(run: RunData) -> str:
    """What the top-down view leaves out: the depth range, unless the run is planar."""
    points = _all_points(run)
    if not len(points) or _planar(run):
        return ""
    return f"; z from {points[:, 2].min():.2f} to {points[:, 2].max():.2f} m, not drawn"


def _draw_3d(ax: Any, run: RunData, colours: dict[int, Any]) -> None:
    """3-D view at equal scale: one metre is as long along z as along x and y (Axes3D: mpl_toolkits is untyped)."""
    for vehicle, series in run.vehicles.items():
        c, p, pd = colours[vehicle], series.position, series.desired
        ax.plot(pd[:, 0], pd[:, 1], pd[:, 2], color=c, lw=1.0, ls="--")
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color=c, lw=1.6)
        if len(p):
            ax.scatter(*p[0], color=c, marker="o", s=30)
            ax.scatter(*pd[0], color=c, marker="x", s=30)
            ax.scatter(*p[-1], color=c, marker="s", s=30)
    points = _all_points(run)
    low, high = points.min(axis=0), points.max(axis=0)
    span = np.maximum(high - low, 1e-3 * max(float(np.ptp(points)), 1.0))  # a zero span would collapse the box
    middle = 0.5 * (low + high)
    ax.set_xlim(middle[0] - span[0] / 2, middle[0] + span[0] / 2)
    ax.set_ylim(middle[1] - span[1] / 2, middle[1] + span[1] / 2)
    ax.set_zlim(middle[2] - span[2] / 2, middle[2] + span[2] / 2)
    ax.set_box_aspect(tuple(span))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m] (up)")
    ax.set_title("3-D, equal scale on x, y and z", fontsize="medium")


# --- Fig. 4, 5: errors ---------------------------------------------------------------------------------------


def fig_path_following_errors(run: RunData) -> Figure:
    """Fig. 4: |p_i - p_d_i| per vehicle with the tube radius."""
    fig = new_figure()
    ax = fig.add_subplot()
    _per_vehicle(ax, run, lambda s: s.error_norm)
    radius = None if run.meta is None else run.meta.tube_radius
    if radius is not None and math.isfinite(radius):
        ax.axhline(float(radius), color="k", ls="--", lw=1.0, label=f"tube radius {float(radius):g} m")
    ax.set_ylim(bottom=0.0)
    finish_time_axes(ax, run, r"$|p_i - p_{d_i}|$ [m]", f"Path-following errors: {run.name}")
    return fig


def aligned(run: RunData, column: Callable[[VehicleSeries], Array]) -> tuple[Array, Array]:
    """(t, values): one column per vehicle (run.vehicles order) on the union of their time stamps; NaN where a
    vehicle has no state (not started yet, down after a kill, its log cut short), so lines break there."""
    stamps = [np.round(s.t, TIME_DECIMALS) for s in run.vehicles.values()]
    t = np.unique(np.concatenate(stamps)) if stamps else np.empty(0)
    values = np.full((len(t), len(stamps)), np.nan)
    for k, (series, own) in enumerate(zip(run.vehicles.values(), stamps, strict=True)):
        values[np.searchsorted(t, own), k] = column(series)
    return t, values


def _per_vehicle(ax: Axes, run: RunData, column: Callable[[VehicleSeries], Array]) -> None:
    """One line per vehicle in its colour, broken where the vehicle was down."""
    t, values = aligned(run, column)
    for k, (vehicle, c) in enumerate(vehicle_colours(run).items()):
        ax.plot(t, values[:, k], color=c, label=f"AUV {vehicle}", gid=VEHICLE)


def fig_coordination_errors(run: RunData) -> Figure:
    """Fig. 5: pairwise gamma_i - gamma_j for small fleets, each vehicle's distance from the fleet's mean gamma for
    larger ones (see the module docstring); the scale from the data's range, so the transient and the steady state
    both show."""
    fig = new_figure(10.0, 5.5)
    ax = fig.add_subplot()
    t, gamma = aligned(run, lambda s: s.gamma)
    if len(run.vehicles) <= PAIRWISE_MAX_VEHICLES:
        errors = _pairwise(ax, run, t, gamma)
        ylabel, what = r"$\gamma_i - \gamma_j$ [-]", "Coordination errors"
    else:
        errors = _from_mean(ax, run, t, gamma)
        ylabel, what = r"$\gamma_i - \bar\gamma$ [-]", "Coordination: each vehicle against the fleet's mean"
    ax.axhline(0.0, color="k", lw=0.6)
    linthresh = symlog_threshold(t, errors)
    if linthresh is None:
        ylabel += " (linear scale)"
    else:
        ax.set_yscale("symlog", linthresh=linthresh)
        ylabel += f" (symlog: linear within $\\pm${linthresh:g})"
    finish_time_axes(ax, run, ylabel, f"{what}: {run.name}")
    return fig


def symlog_threshold(t: Array, errors: Array) -> float | None:
    """The symlog axis's linear band for these errors (one column per line, or one line), or None for a linear
    axis: from the data's range, as the module docstring says."""
    if not t.size:  # a log without states (a run stopped before its first step, recovered): a linear axis
        return None
    size = np.abs(errors).reshape(len(t), -1)
    known = np.isfinite(size).any(axis=1)
    if not known.any():
        return None
    spread = np.where(np.isfinite(size), size, 0.0).max(axis=1)[known]
    peak = float(spread.max())
    levels = []
    for part in (0.5, 0.9):  # the second half (a fault late in the run still leaves it quiet stretches), the end
        late = spread[t[known] >= t[0] + part * (t[-1] - t[0])]
        late = late[late > 0.0]
        if late.size:
            levels.append(float(np.percentile(late, 10)))
    if peak <= 0.0 or not levels:
        return None
    level = min(levels)
    if peak < level * 10.0**SYMLOG_DECADES:
        return None
    return float(10.0 ** math.floor(math.log10(level)))


def _pairwise(ax: Axes, run: RunData, t: Array, gamma: Array) -> Array:
    """gamma_i - gamma_j of every pair, one line each; returns them, one column per pair."""
    ids = list(run.vehicles)
    pairs = list(itertools.combinations(range(len(ids)), 2))
    errors = np.empty((len(t), len(pairs)))
    for k, ((a, b), c) in enumerate(zip(pairs, distinct_colours(len(pairs)), strict=True)):
        errors[:, k] = gamma[:, a] - gamma[:, b]
        ax.plot(t, errors[:, k], color=c, label=rf"$\gamma_{{{ids[a]}}} - \gamma_{{{ids[b]}}}$")
    return errors


def _from_mean(ax: Axes, run: RunData, t: Array, gamma: Array) -> Array:
    """gamma_i minus the mean over the vehicles alive at each instant, and the fleet's spread (max - min); returns
    the spread."""
    alive = np.isfinite(gamma).any(axis=1)
    mean, spread = np.full(len(t), np.nan), np.full(len(t), np.nan)
    mean[alive] = np.nanmean(gamma[alive], axis=1)
    spread[alive] = np.nanmax(gamma[alive], axis=1) - np.nanmin(gamma[alive], axis=1)
    colours = vehicle_colours(run)
    for column, vehicle in enumerate(run.vehicles):
        ax.plot(
            t, gamma[:, column] - mean, color=colours[vehicle], lw=1.2, label=rf"$\gamma_{{{vehicle}}}$", gid=VEHICLE
        )
    ax.plot(t, spread, color="k", lw=2.0, ls=":", label=r"spread $\max_i \gamma_i - \min_i \gamma_i$")
    return spread


# --- Figs. 6-8 and gamma_dot ---------------------------------------------------------------------------------


def fig_velocities(run: RunData, series: VehicleSeries) -> Figure:
    """Figs. 6-8: surge u, sway v and heave w of one vehicle, stacked."""
    title = f"Linear velocities of AUV {series.vehicle} (body frame): {run.name}"
    fig, axes = panel_grid(9.0, 7.0, 3, 1, title, titled=False)
    names = (("u", "surge"), ("v", "sway"), ("w", "heave"))
    for k, (ax, (symbol, name)) in enumerate(zip(axes, names, strict=True)):
        ax.plot(series.t, series.velocity[:, k], color=colour(k), label=f"{symbol} ({name})")
        finish_time_axes(ax, run, f"{symbol} [m/s]")
        if k < 2:
            ax.set_xlabel("")
    return fig


def path_specs(run: RunData) -> list[dict[str, Any]]:
    """The vehicles' path specs as the run's scenario gave them (none for a log without one)."""
    scenario = run.meta.scenario if run.meta is not None else {}
    return [v["path"] for v in scenario.get("vehicles", []) if isinstance(v, dict) and isinstance(v.get("path"), dict)]


def fig_gamma_dot(run: RunData) -> Figure:
    """Speed of each virtual target along its path."""
    fig = new_figure()
    ax = fig.add_subplot()
    _per_vehicle(ax, run, lambda s: s.gamma_dot)
    unit = rate_label(gamma_unit(path_specs(run)))  # the paths' own: a line's gamma is metres, a helix's a number
    finish_time_axes(ax, run, rf"$\dot\gamma_i$ [{unit}]", f"Path parameter rates: {run.name}")
    return fig

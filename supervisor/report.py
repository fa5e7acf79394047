"""Figures of a recorded run, analogous to Figs. 3-8 of Aguiar & Pascoal's coordinated path-following paper.

``load_run`` turns a run's MCAP into per-vehicle numpy arrays, fault intervals and the communication graph;
``write_figures`` renders the PNGs. Figures are built on ``matplotlib.figure.Figure`` directly (Agg canvas,
no pyplot), so nothing touches global plotting state and the module is safe to use from tests and threads.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple, TypeAlias

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from comms.messages import FAULT_KEY, GRAPH_KEY, META_KEY, vehicle_of_key
from supervisor.recorder import read_messages

__all__ = ["DPI", "FaultInterval", "RunData", "VehicleSeries", "load_run", "write_figures"]

Array: TypeAlias = NDArray[np.float64]
Edge: TypeAlias = tuple[int, int]

DPI = 120
FAULT_COLOUR = "tab:red"
FAULT_ALPHA = 0.15
FAULT_HATCHES = ("", "//", "\\\\", "xx", "..")  # tells distinct fault labels apart under one colour
SYMLOG_LINTHRESH = 1e-3


# --- data ---------------------------------------------------------------------------------------------------


class FaultInterval(NamedTuple):
    """A fault active on [start, end] s of simulation time."""

    kind: str
    start: float
    end: float
    label: str


@dataclass(frozen=True, eq=False)
class VehicleSeries:
    """One vehicle's telemetry, one row per recorded step, in time order."""

    vehicle: int
    t: Array
    gamma: Array
    gamma_dot: Array
    position: Array  # (n, 3) inertial, m
    velocity: Array  # (n, 3) body frame [u, v, w], m/s
    error: Array  # (n, 3) p - p_d(gamma), inertial, m
    tau: Array  # (n, k) control inputs
    correction: Array
    lyapunov: Array

    @property
    def desired(self) -> Array:
        """p_d(gamma) recovered from the recorded position and error."""
        return self.position - self.error

    @property
    def error_norm(self) -> Array:
        return np.linalg.norm(self.error, axis=1)


@dataclass(frozen=True, eq=False)
class RunData:
    """Everything the figures need from one run."""

    meta: dict[str, Any]
    vehicles: dict[int, VehicleSeries]  # by vehicle id, ascending
    faults: list[FaultInterval]
    edges: list[Edge]  # communication graph at the start of the run (from meta)
    graph_changes: list[tuple[float, list[Edge]]] = field(default_factory=list)  # (t, edges) from cpf/run/graph

    @property
    def name(self) -> str:
        return str(self.meta.get("scenario_name", "run"))

    @property
    def t_range(self) -> tuple[float, float]:
        return _time_range(self.vehicles, self.meta)


def _time_range(vehicles: dict[int, VehicleSeries], meta: dict[str, Any]) -> tuple[float, float]:
    """First and last recorded state time; [0, meta duration] when there are no states."""
    series = [s for s in vehicles.values() if s.t.size]
    if not series:
        return 0.0, float(meta.get("duration", 0.0))
    return min(float(s.t[0]) for s in series), max(float(s.t[-1]) for s in series)


def load_run(path: Path) -> RunData:
    """Read a run's MCAP into arrays."""
    meta: dict[str, Any] = {}
    states: dict[int, list[dict[str, Any]]] = {}
    fault_events: list[dict[str, Any]] = []
    graph_changes: list[tuple[float, list[Edge]]] = []
    for topic, _, message in read_messages(path):
        owned = vehicle_of_key(topic)
        if owned is not None:
            if owned[1] == "state":
                states.setdefault(owned[0], []).append(message)
        elif topic == META_KEY:
            meta = message
        elif topic == FAULT_KEY:
            fault_events.append(message)
        elif topic == GRAPH_KEY:
            graph_changes.append((float(message["t"]), _edges(message.get("edges", []))))
    vehicles = {v: _series(v, states[v]) for v in sorted(states)}
    start, end = _time_range(vehicles, meta)
    faults = _intervals_from_events(fault_events, start, end) if fault_events else _intervals_from_meta(meta, end)
    return RunData(meta, vehicles, faults, _edges(meta.get("edges", [])), graph_changes)


def _edges(pairs: Iterable[Sequence[Any]]) -> list[Edge]:
    return [(int(i), int(j)) for i, j in pairs]


def _series(vehicle: int, messages: list[dict[str, Any]]) -> VehicleSeries:
    def column(name: str) -> Array:
        return np.array([m[name] for m in messages], dtype=float)

    return VehicleSeries(
        vehicle=vehicle,
        t=column("t"),
        gamma=column("gamma"),
        gamma_dot=column("gamma_dot"),
        position=_matrix([m["position"] for m in messages], 3),
        velocity=_matrix([m["velocity"] for m in messages], 3),
        error=_matrix([m["error"] for m in messages], 3),
        tau=_matrix([m["tau"] for m in messages]),
        correction=column("correction"),
        lyapunov=column("lyapunov"),
    )


def _matrix(rows: list[list[float]], width: int | None = None) -> Array:
    """Rows as an (n, width) array; ragged rows (e.g. tau changing length) are NaN-padded, not rejected."""
    width = width if width is not None else max((len(r) for r in rows), default=0)
    if all(len(r) == width for r in rows):
        return np.array(rows, dtype=float).reshape(len(rows), width)
    out = np.full((len(rows), width), np.nan)
    for k, row in enumerate(rows):
        out[k, : len(row)] = row[:width]
    return out


def _fault_label(kind: str, vehicle: Any) -> str:
    return kind if vehicle is None else f"{kind} (AUV {vehicle})"


def _intervals_from_events(events: list[dict[str, Any]], run_start: float, run_end: float) -> list[FaultInterval]:
    """Pair start/end events per (kind, vehicle); an open start runs to the end, an orphan end from t0."""
    open_faults: list[tuple[str, Any, float]] = []
    intervals: list[FaultInterval] = []
    for event in events:
        kind, vehicle, t = str(event["kind"]), _event_vehicle(event), float(event["t"])
        if event["phase"] == "start":
            open_faults.append((kind, vehicle, t))
            continue
        match = _find_open(open_faults, kind, vehicle)
        start = run_start  # an end without a start: the fault was active from the beginning
        if match is not None:
            _, vehicle, start = open_faults.pop(match)
        intervals.append(FaultInterval(kind, start, t, _fault_label(kind, vehicle)))
    intervals += [FaultInterval(k, t, max(run_end, t), _fault_label(k, v)) for k, v, t in open_faults]
    return sorted(intervals, key=lambda f: (f.start, f.end))


def _event_vehicle(event: dict[str, Any]) -> Any:
    """The vehicle of a fault event (detail per the schema, top level tolerated); None if fleet-wide."""
    return event.get("vehicle", (event.get("detail") or {}).get("vehicle"))


def _find_open(open_faults: list[tuple[str, Any, float]], kind: str, vehicle: Any) -> int | None:
    """Oldest open fault of this kind and vehicle; an end event without a vehicle closes any vehicle's."""
    for k, (open_kind, open_vehicle, _) in enumerate(open_faults):
        if open_kind == kind and (vehicle is None or open_vehicle == vehicle):
            return k
    return None


def _intervals_from_meta(meta: dict[str, Any], run_end: float) -> list[FaultInterval]:
    """The scenario's planned faults, for runs that recorded no fault events."""
    intervals = []
    for fault in meta.get("faults", []):
        kind, end = str(fault["kind"]), fault.get("end")
        end = run_end if end is None else float(end)
        intervals.append(FaultInterval(kind, float(fault["start"]), end, _fault_label(kind, fault.get("vehicle"))))
    return sorted(intervals, key=lambda f: (f.start, f.end))


# --- figures ------------------------------------------------------------------------------------------------


def write_figures(run: RunData, out_dir: Path) -> list[Path]:
    """Render every figure of the run into out_dir as PNG; returns the paths written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    figures: list[tuple[str, Callable[[RunData], Figure]]] = [
        ("fig3_trajectories.png", _fig_trajectories),
        ("fig4_path_following_errors.png", _fig_path_following_errors),
        ("fig5_coordination_errors.png", _fig_coordination_errors),
    ]
    figures += [(f"fig6_velocities_auv{v}.png", _velocities_figure(v)) for v in run.vehicles]
    figures.append(("gamma_dot.png", _fig_gamma_dot))
    return [_save(build(run), out_dir / name) for name, build in figures]


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)  # explicit Agg canvas: no dependency on the configured backend
    fig.savefig(path, dpi=DPI)
    return path


def _new_figure(width: float = 9.0, height: float = 5.0) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def _colour(index: int) -> str:
    return f"C{index % 10}"


def _shade_faults(ax: Axes, faults: Sequence[FaultInterval]) -> None:
    """Light red band per fault interval; each distinct label enters the legend once."""
    hatches = {
        label: FAULT_HATCHES[k % len(FAULT_HATCHES)] for k, label in enumerate(dict.fromkeys(f.label for f in faults))
    }
    seen: set[str] = set()
    for fault in faults:
        label = fault.label if fault.label not in seen else "_nolegend_"
        seen.add(fault.label)
        ax.axvspan(
            fault.start,
            fault.end,
            color=FAULT_COLOUR,
            alpha=FAULT_ALPHA,
            hatch=hatches[fault.label],
            label=label,
        )


def _finish_time_axes(ax: Axes, run: RunData, ylabel: str, title: str | None = None) -> None:
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
    if ax.get_legend_handles_labels()[0]:  # an empty legend call warns, and warnings fail the tests
        ax.legend(loc="best", fontsize="small")


def _fig_trajectories(run: RunData) -> Figure:
    """Fig. 3: actual (solid) and desired (dashed) trajectories in 3-D, start points marked."""
    fig = _new_figure(8.0, 7.0)
    ax: Any = fig.add_subplot(projection="3d")  # Axes3D: mpl_toolkits is untyped
    for k, series in enumerate(run.vehicles.values()):
        colour, p, pd = _colour(k), series.position, series.desired
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color=colour, lw=1.4, label=f"AUV {series.vehicle}")
        ax.plot(pd[:, 0], pd[:, 1], pd[:, 2], color=colour, lw=1.0, ls="--", label=f"path {series.vehicle}")
        if len(p):
            ax.scatter(*p[0], color=colour, marker="o", s=40)
            ax.scatter(*pd[0], color=colour, marker="x", s=40)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"Coordinated path-following: {run.name}\n(solid: vehicle, dashed: desired path, o/x: start)")
    if run.vehicles:
        ax.legend(loc="upper left", fontsize="small", ncols=2)
    return fig


def _fig_path_following_errors(run: RunData) -> Figure:
    """Fig. 4: |p_i - p_d_i| per vehicle with the tube radius."""
    fig = _new_figure()
    ax = fig.add_subplot()
    for k, series in enumerate(run.vehicles.values()):
        ax.plot(series.t, series.error_norm, color=_colour(k), label=f"AUV {series.vehicle}")
    radius = run.meta.get("tube_radius")
    if radius is not None:
        ax.axhline(float(radius), color="k", ls="--", lw=1.0, label=f"tube radius {float(radius):g} m")
    ax.set_ylim(bottom=0.0)
    _finish_time_axes(ax, run, r"$|p_i - p_{d_i}|$ [m]", f"Path-following errors: {run.name}")
    return fig


def _fig_coordination_errors(run: RunData) -> Figure:
    """Fig. 5: gamma_i - gamma_j for every pair i < j, symlog so transient and steady state both show."""
    fig = _new_figure()
    ax = fig.add_subplot()
    for k, (a, b) in enumerate(itertools.combinations(run.vehicles.values(), 2)):
        t, diff = _difference(a, b)
        ax.plot(t, diff, color=_colour(k), label=rf"$\gamma_{{{a.vehicle}}} - \gamma_{{{b.vehicle}}}$")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_yscale("symlog", linthresh=SYMLOG_LINTHRESH)
    _finish_time_axes(ax, run, r"$\gamma_i - \gamma_j$ [-] (symlog)", f"Coordination errors: {run.name}")
    return fig


def _difference(a: VehicleSeries, b: VehicleSeries) -> tuple[Array, Array]:
    """gamma_a - gamma_b on a's time stamps within the common time span (b interpolated if stamps differ)."""
    if a.t.shape == b.t.shape and np.array_equal(a.t, b.t):
        return a.t, a.gamma - b.gamma
    if not (a.t.size and b.t.size):
        return np.empty(0), np.empty(0)
    keep = (a.t >= b.t[0]) & (a.t <= b.t[-1])
    return a.t[keep], a.gamma[keep] - np.interp(a.t[keep], b.t, b.gamma)


def _velocities_figure(vehicle: int) -> Callable[[RunData], Figure]:
    def build(run: RunData) -> Figure:
        return _fig_velocities(run, run.vehicles[vehicle])

    return build


def _fig_velocities(run: RunData, series: VehicleSeries) -> Figure:
    """Figs. 6-8: surge u, sway v and heave w of one vehicle, stacked."""
    fig = _new_figure(9.0, 7.0)
    axes = fig.subplots(3, 1, sharex=True)
    names = (("u", "surge"), ("v", "sway"), ("w", "heave"))
    for k, (ax, (symbol, name)) in enumerate(zip(axes, names, strict=True)):
        ax.plot(series.t, series.velocity[:, k], color=_colour(k), label=f"{symbol} ({name})")
        _finish_time_axes(ax, run, f"{symbol} [m/s]")
        if k < 2:
            ax.set_xlabel("")
    fig.suptitle(f"Linear velocities of AUV {series.vehicle} (body frame): {run.name}")
    return fig


def _fig_gamma_dot(run: RunData) -> Figure:
    """Speed of each virtual target along its path."""
    fig = _new_figure()
    ax = fig.add_subplot()
    for k, series in enumerate(run.vehicles.values()):
        ax.plot(series.t, series.gamma_dot, color=_colour(k), label=f"AUV {series.vehicle}")
    _finish_time_axes(ax, run, r"$\dot\gamma_i$ [1/s]", f"Path parameter rates: {run.name}")
    return fig

"""Figures of a recorded run, analogous to Figs. 3-8 of Aguiar & Pascoal's coordinated path-following paper, and
of its acoustic channel.

``load_run`` turns a run's MCAP into per-vehicle numpy arrays, fault intervals, the communication graph, every link
event per directed link, the broker's stats snapshots and the age of each vehicle's neighbour estimates (it skips
the vehicles' tx and rx messages, which the link events cover; a log cut short is read up to its cut).
``write_figures`` renders the PNGs (the channel's in supervisor.report_comms); ``write_report`` adds metrics.json
(supervisor.metrics). Figures are built on ``matplotlib.figure.Figure`` directly (Agg canvas, no pyplot), so
nothing touches global plotting state and the module is safe to use from tests and threads.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple, TypeAlias

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from comms.messages import COMMS_EVENT_KEY, COMMS_STATS_KEY, FAULT_KEY, GRAPH_KEY, META_KEY, vehicle_of_key
from supervisor.info import read_raw

__all__ = [
    "DPI",
    "AgeSeries",
    "FaultInterval",
    "LinkLog",
    "RunData",
    "VehicleSeries",
    "load_run",
    "write_figures",
    "write_report",
]

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


class AgeSeries(NamedTuple):
    """How old one vehicle's estimate of one neighbour was, at each step it held one."""

    t: Array
    age: Array  # s since the estimate's time stamp


@dataclass(frozen=True, eq=False)
class LinkLog:
    """Every cpf/comms/event of one directed link, in time order."""

    sender: int
    receiver: int
    t: Array  # s: a sent packet at transmission, a delivered one at arrival, a dropped one when it was given up
    kind: NDArray[np.str_]  # "sent" | "delivered" | "dropped"
    delay: Array  # s from transmission to arrival; NaN unless delivered
    reason: NDArray[np.str_]  # why it was dropped; "" unless dropped

    @property
    def name(self) -> str:
        return f"{self.sender}->{self.receiver}"

    def times(self, kind: str) -> Array:
        """Times of the events of one kind."""
        return self.t[self.kind == kind]

    @property
    def delays(self) -> Array:
        return self.delay[self.kind == "delivered"]

    def dropped_by_cause(self) -> dict[str, int]:
        causes, counts = np.unique(self.reason[self.kind == "dropped"], return_counts=True)
        return {str(c): int(n) for c, n in zip(causes, counts, strict=True)}


@dataclass(frozen=True, eq=False)
class RunData:
    """Everything the figures and metrics need from one run."""

    meta: dict[str, Any]
    vehicles: dict[int, VehicleSeries]  # by vehicle id, ascending
    faults: list[FaultInterval]
    edges: list[Edge]  # communication graph at the start of the run (from meta)
    graph_changes: list[tuple[float, list[Edge]]] = field(default_factory=list)  # (t, edges) from cpf/run/graph
    links: dict[Edge, LinkLog] = field(default_factory=dict)  # (sender, receiver) -> events, ascending
    stats: list[dict[str, Any]] = field(default_factory=list)  # cpf/comms/stats snapshots, in time order
    estimate_ages: dict[Edge, AgeSeries] = field(default_factory=dict)  # (neighbour, holder): the age of what the
    # holder knows of the neighbour, i.e. keyed like the link the information travels on

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


RUN_TOPICS = frozenset({META_KEY, FAULT_KEY, GRAPH_KEY, COMMS_EVENT_KEY, COMMS_STATS_KEY})


def _wanted(topic: str) -> bool:
    """What the report reads: everything but the vehicles' transmissions and receptions (the events cover them)."""
    owned = vehicle_of_key(topic)
    return topic in RUN_TOPICS if owned is None else owned[1] == "state"


@dataclass
class _Collected:
    meta: dict[str, Any] = field(default_factory=dict)
    states: dict[int, list[dict[str, Any]]] = field(default_factory=dict)
    fault_events: list[dict[str, Any]] = field(default_factory=list)
    graph_changes: list[tuple[float, list[Edge]]] = field(default_factory=list)
    link_events: dict[Edge, list[dict[str, Any]]] = field(default_factory=dict)
    stats: list[dict[str, Any]] = field(default_factory=list)

    def add(self, topic: str, message: dict[str, Any]) -> None:
        owned = vehicle_of_key(topic)
        if owned is not None:
            self.states.setdefault(owned[0], []).append(message)
        elif topic == COMMS_EVENT_KEY:
            self.link_events.setdefault((int(message["sender"]), int(message["receiver"])), []).append(message)
        elif topic == META_KEY:
            self.meta = message
        elif topic == FAULT_KEY:
            self.fault_events.append(message)
        elif topic == GRAPH_KEY:
            self.graph_changes.append((float(message["t"]), _edges(message.get("edges", []))))
        elif topic == COMMS_STATS_KEY:
            self.stats.append(message)


def load_run(path: Path) -> RunData:
    """Read a run's MCAP into arrays (a log cut short is read as far as it goes; LogError if not an MCAP)."""
    got = _Collected()
    for message in read_raw(path, _wanted).messages:
        got.add(message.topic, json.loads(message.data))
    vehicles = {v: _series(v, got.states[v]) for v in sorted(got.states)}
    start, end = _time_range(vehicles, got.meta)
    events = got.fault_events
    faults = _intervals_from_events(events, start, end) if events else _intervals_from_meta(got.meta, end)
    return RunData(
        got.meta, vehicles, faults, _edges(got.meta.get("edges", [])), got.graph_changes,
        {link: _link_log(link, got.link_events[link]) for link in sorted(got.link_events)},
        got.stats, _estimate_ages(got.states),
    )  # fmt: skip


def _link_log(link: Edge, events: list[dict[str, Any]]) -> LinkLog:
    delays = [np.nan if e.get("delay") is None else e["delay"] for e in events]
    return LinkLog(
        link[0], link[1],
        np.array([e["t"] for e in events], dtype=float),
        np.array([e["kind"] for e in events], dtype=str),
        np.array(delays, dtype=float),
        np.array([e.get("reason") or "" for e in events], dtype=str),
    )  # fmt: skip


def _estimate_ages(states: dict[int, list[dict[str, Any]]]) -> dict[Edge, AgeSeries]:
    """(neighbour, holder) -> ages, from the estimate_age field of every state message."""
    rows: dict[Edge, tuple[list[float], list[float]]] = {}
    for holder, messages in states.items():
        for m in messages:
            for neighbour, age in m.get("estimate_age", ()):
                t, ages = rows.setdefault((int(neighbour), holder), ([], []))
                t.append(m["t"])
                ages.append(age)
    return {key: AgeSeries(np.array(t, dtype=float), np.array(a, dtype=float)) for key, (t, a) in sorted(rows.items())}


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


def _fault_label(kind: str, target: str | None) -> str:
    return kind if target is None else f"{kind} ({target})"


def _fault_target(fields: dict[str, Any]) -> str | None:
    """What a fault acts on: 'AUV 2', 'link 1->2' ('1<->2' both ways); None if fleet- or network-wide."""
    if fields.get("vehicle") is not None:
        return f"AUV {fields['vehicle']}"
    if fields.get("sender") is not None:
        return f"link {fields['sender']}{'<->' if fields.get('both') else '->'}{fields.get('receiver')}"
    return None


def _intervals_from_events(events: list[dict[str, Any]], run_start: float, run_end: float) -> list[FaultInterval]:
    """Pair start/end events per (kind, target); an open start runs to the end, an orphan end from t0."""
    open_faults: list[tuple[str, str | None, float]] = []
    intervals: list[FaultInterval] = []
    for event in events:
        kind, target, t = str(event["kind"]), _event_target(event), float(event["t"])
        if event["phase"] == "start":
            open_faults.append((kind, target, t))
            continue
        match = _find_open(open_faults, kind, target)
        start = run_start  # an end without a start: the fault was active from the beginning
        if match is not None:
            _, target, start = open_faults.pop(match)
        intervals.append(FaultInterval(kind, start, t, _fault_label(kind, target)))
    intervals += [FaultInterval(k, t, max(run_end, t), _fault_label(k, v)) for k, v, t in open_faults]
    return sorted(intervals, key=lambda f: (f.start, f.end))


def _event_target(event: dict[str, Any]) -> str | None:
    """The target of a fault event (detail per the schema, top level tolerated); None if fleet-wide."""
    return _fault_target({**(event.get("detail") or {}), **event})


def _find_open(open_faults: list[tuple[str, str | None, float]], kind: str, target: str | None) -> int | None:
    """Oldest open fault of this kind and target; an end event without a target closes any target's."""
    for k, (open_kind, open_target, _) in enumerate(open_faults):
        if open_kind == kind and (target is None or open_target == target):
            return k
    return None


def _intervals_from_meta(meta: dict[str, Any], run_end: float) -> list[FaultInterval]:
    """The scenario's planned faults, for runs that recorded no fault events."""
    intervals = []
    for fault in meta.get("faults", []):
        kind, end = str(fault["kind"]), fault.get("end")
        end = run_end if end is None else float(end)
        intervals.append(FaultInterval(kind, float(fault["start"]), end, _fault_label(kind, _fault_target(fault))))
    return sorted(intervals, key=lambda f: (f.start, f.end))


# --- figures ------------------------------------------------------------------------------------------------


METRICS_FILE = "metrics.json"


def write_report(log: Path, out_dir: Path) -> list[Path]:
    """Every figure of a recorded run and its metrics (metrics.json) into out_dir; returns the paths written."""
    from supervisor.metrics import run_metrics

    run = load_run(log)
    paths = write_figures(run, out_dir)
    metrics = out_dir / METRICS_FILE
    metrics.write_text(json.dumps(run_metrics(run), indent=2, allow_nan=False) + "\n", encoding="utf-8")
    return [*paths, metrics]


def write_figures(run: RunData, out_dir: Path) -> list[Path]:
    """Render every figure of the run into out_dir as PNG; returns the paths written.

    The paper's analogues (fig3-fig6, gamma_dot), then the channel's (comms_*: supervisor.report_comms)."""
    from supervisor.report_comms import comms_figures  # it builds on this module's data and helpers

    out_dir.mkdir(parents=True, exist_ok=True)
    figures: list[tuple[str, Callable[[RunData], Figure]]] = [
        ("fig3_trajectories.png", _fig_trajectories),
        ("fig4_path_following_errors.png", _fig_path_following_errors),
        ("fig5_coordination_errors.png", _fig_coordination_errors),
    ]
    figures += [(f"fig6_velocities_auv{v}.png", _velocities_figure(v)) for v in run.vehicles]
    figures.append(("gamma_dot.png", _fig_gamma_dot))
    figures += comms_figures(run)
    return [_save(build(run), out_dir / name) for name, build in figures]


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)  # explicit Agg canvas: no dependency on the configured backend
    fig.savefig(path, dpi=DPI)
    return path


def new_figure(width: float = 9.0, height: float = 5.0) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def colour(index: int) -> str:
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
    if ax.get_legend_handles_labels()[0]:  # an empty legend call warns, and warnings fail the tests
        ax.legend(loc="best", fontsize="small")


def _fig_trajectories(run: RunData) -> Figure:
    """Fig. 3: actual (solid) and desired (dashed) trajectories in 3-D, start points marked."""
    fig = new_figure(8.0, 7.0)
    ax: Any = fig.add_subplot(projection="3d")  # Axes3D: mpl_toolkits is untyped
    for k, series in enumerate(run.vehicles.values()):
        c, p, pd = colour(k), series.position, series.desired
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color=c, lw=1.4, label=f"AUV {series.vehicle}")
        ax.plot(pd[:, 0], pd[:, 1], pd[:, 2], color=c, lw=1.0, ls="--", label=f"path {series.vehicle}")
        if len(p):
            ax.scatter(*p[0], color=c, marker="o", s=40)
            ax.scatter(*pd[0], color=c, marker="x", s=40)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"Coordinated path-following: {run.name}\n(solid: vehicle, dashed: desired path, o/x: start)")
    if run.vehicles:
        ax.legend(loc="upper left", fontsize="small", ncols=2)
    return fig


def _fig_path_following_errors(run: RunData) -> Figure:
    """Fig. 4: |p_i - p_d_i| per vehicle with the tube radius."""
    fig = new_figure()
    ax = fig.add_subplot()
    for k, series in enumerate(run.vehicles.values()):
        ax.plot(series.t, series.error_norm, color=colour(k), label=f"AUV {series.vehicle}")
    radius = run.meta.get("tube_radius")
    if radius is not None:
        ax.axhline(float(radius), color="k", ls="--", lw=1.0, label=f"tube radius {float(radius):g} m")
    ax.set_ylim(bottom=0.0)
    finish_time_axes(ax, run, r"$|p_i - p_{d_i}|$ [m]", f"Path-following errors: {run.name}")
    return fig


def _fig_coordination_errors(run: RunData) -> Figure:
    """Fig. 5: gamma_i - gamma_j for every pair i < j, symlog so transient and steady state both show."""
    fig = new_figure()
    ax = fig.add_subplot()
    for k, (a, b) in enumerate(itertools.combinations(run.vehicles.values(), 2)):
        t, diff = _difference(a, b)
        ax.plot(t, diff, color=colour(k), label=rf"$\gamma_{{{a.vehicle}}} - \gamma_{{{b.vehicle}}}$")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_yscale("symlog", linthresh=SYMLOG_LINTHRESH)
    finish_time_axes(ax, run, r"$\gamma_i - \gamma_j$ [-] (symlog)", f"Coordination errors: {run.name}")
    return fig


def _difference(a: VehicleSeries, b: VehicleSeries) -> tuple[Array, Array]:
    """gamma_a - gamma_b on a's time stamps within the common time span (b interpolated if stamps differ)."""
    if a.t.shape == b.t.shape and np.array_equal(a.t, b.t):
        return a.t, a.gamma - b.gamma
    if not (a.t.size and b.t.size):
        return np.empty(0), np.empty(0)
    keep = (a.t >= b.t[0]) & (a.t <= b.t[-1])
    t, diff = a.t[keep], a.gamma[keep] - np.interp(a.t[keep], b.t, b.gamma)
    gaps = np.diff(b.t)
    if gaps.size:  # where b was down (a gap in its states), there is no difference: NaN, not an interpolated one
        after = np.clip(np.searchsorted(b.t, t), 1, b.t.size - 1)
        diff[(b.t[after] - b.t[after - 1] > 1.5 * np.median(gaps)) & (b.t[after - 1] < t) & (t < b.t[after])] = np.nan
    return t, diff


def _velocities_figure(vehicle: int) -> Callable[[RunData], Figure]:
    def build(run: RunData) -> Figure:
        return _fig_velocities(run, run.vehicles[vehicle])

    return build


def _fig_velocities(run: RunData, series: VehicleSeries) -> Figure:
    """Figs. 6-8: surge u, sway v and heave w of one vehicle, stacked."""
    fig = new_figure(9.0, 7.0)
    axes = fig.subplots(3, 1, sharex=True)
    names = (("u", "surge"), ("v", "sway"), ("w", "heave"))
    for k, (ax, (symbol, name)) in enumerate(zip(axes, names, strict=True)):
        ax.plot(series.t, series.velocity[:, k], color=colour(k), label=f"{symbol} ({name})")
        finish_time_axes(ax, run, f"{symbol} [m/s]")
        if k < 2:
            ax.set_xlabel("")
    fig.suptitle(f"Linear velocities of AUV {series.vehicle} (body frame): {run.name}")
    return fig


def _fig_gamma_dot(run: RunData) -> Figure:
    """Speed of each virtual target along its path."""
    fig = new_figure()
    ax = fig.add_subplot()
    for k, series in enumerate(run.vehicles.values()):
        ax.plot(series.t, series.gamma_dot, color=colour(k), label=f"AUV {series.vehicle}")
    finish_time_axes(ax, run, r"$\dot\gamma_i$ [1/s]", f"Path parameter rates: {run.name}")
    return fig

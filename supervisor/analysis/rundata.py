"""A recorded run as numpy arrays: ``load_run`` reads a run's MCAP (through the strict reader, record.logfile)
into per-vehicle series, fault intervals, the communication graph, every link event per directed link, the
broker's stats snapshots and the age of each vehicle's neighbour estimates (it skips the vehicles' tx and rx
messages, which the link events cover; a log cut short is refused: `cpf recover` first). The figures, the metrics
and the report build on it; it builds on none of them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, TypeAlias

import numpy as np
from numpy.typing import NDArray

from comms.records.events import EVENT_TOPICS, logged_events
from comms.records.messages import COMMS_STATS_KEY, FAULT_KEY, GRAPH_KEY, META_KEY, vehicle_of_key
from comms.records.records import LinkEvent
from comms.records.reports import BusDrops, CommsStats
from comms.records.run import FaultEvent, Graph
from comms.records.state import StateReport
from numerics.linalg import row_norms
from supervisor.analysis.log_drops import DoneReports, is_done_topic
from supervisor.errors import LogError, ScenarioError
from supervisor.record import logfile
from supervisor.record.meta import RunMeta
from supervisor.record.unusable import Unusable

if TYPE_CHECKING:
    from supervisor.analysis.tx_books import BooksLog

Array: TypeAlias = NDArray[np.float64]
Edge: TypeAlias = tuple[int, int]


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
    # With navigation on: |p_hat - p|, the filter's position 1-sigma (root of its covariance's trace), nav_fix codes
    nav_error: Array | None = None
    nav_sigma: Array | None = None
    nav_fix: Array | None = None
    # With a current observer on (vehicles.current_observer): its estimate of the current, (n, 3) inertial, m/s
    current_estimate: Array | None = None

    @property
    def desired(self) -> Array:
        """p_d(gamma) recovered from the recorded position and error."""
        return self.position - self.error

    @property
    def error_norm(self) -> Array:
        return row_norms(self.error)


class AgeSeries(NamedTuple):
    """How old one vehicle's estimate of one neighbour was, at each step it held one."""

    t: Array
    age: Array  # s since the estimate's time stamp


@dataclass(frozen=True, eq=False)
class LinkLog:
    """Every link event of one directed link (cpf/comms/events), in time order."""

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

    meta: RunMeta | None  # the cpf/run/meta record; None if the log has none
    vehicles: dict[int, VehicleSeries]  # by vehicle id, ascending
    faults: list[FaultInterval]
    edges: list[Edge]  # communication graph at the start of the run (from meta)
    graph_changes: list[tuple[float, list[Edge]]] = field(default_factory=list)  # (t, edges) from cpf/run/graph
    links: dict[Edge, LinkLog] = field(default_factory=dict)  # (sender, receiver) -> events, ascending
    stats: list[CommsStats] = field(default_factory=list)  # cpf/comms/stats snapshots, in time order
    estimate_ages: dict[Edge, AgeSeries] = field(default_factory=dict)  # (neighbour, holder): the age of what the
    # holder knows of the neighbour, i.e. keyed like the link the information travels on
    drops: BusDrops = field(default_factory=lambda: BusDrops({}, {}))  # what the bus's readers dropped, from their
    # end-of-run reports (none in process: no bus)

    @property
    def name(self) -> str:
        return "run" if self.meta is None else self.meta.scenario_name

    @property
    def t_range(self) -> tuple[float, float]:
        return _time_range(self.vehicles, self.meta)


def _time_range(vehicles: dict[int, VehicleSeries], meta: RunMeta | None) -> tuple[float, float]:
    """First and last recorded state time; [0, meta duration] when there are no states."""
    series = [s for s in vehicles.values() if s.t.size]
    if not series:
        return 0.0, 0.0 if meta is None else meta.duration
    return min(float(s.t[0]) for s in series), max(float(s.t[-1]) for s in series)


RUN_TOPICS = frozenset({META_KEY, FAULT_KEY, GRAPH_KEY, COMMS_STATS_KEY, *EVENT_TOPICS})


def _wanted(topic: str) -> bool:
    """What the report reads: everything but the vehicles' transmissions and receptions (the events cover them)."""
    owned = vehicle_of_key(topic)
    return is_done_topic(topic) or (topic in RUN_TOPICS if owned is None else owned[1] == "state")


@dataclass
class _Collected:
    """The records of a log, each read through its record type (ValueError naming the field if one does not)."""

    meta: RunMeta | None = None
    states: dict[int, list[StateReport]] = field(default_factory=dict)
    fault_events: list[FaultEvent] = field(default_factory=list)
    graph_changes: list[tuple[float, list[Edge]]] = field(default_factory=list)
    link_events: dict[Edge, list[LinkEvent]] = field(default_factory=dict)
    stats: list[CommsStats] = field(default_factory=list)
    dones: DoneReports = field(default_factory=DoneReports)  # the readers' end-of-run reports

    def empty(self) -> bool:
        return self.meta is None and not (self.states or self.fault_events or self.graph_changes or self.link_events
                                          or self.stats)  # fmt: skip

    def add(self, topic: str, message: dict[str, Any]) -> None:
        owned = vehicle_of_key(topic)
        if is_done_topic(topic):
            self.dones.add(topic, message)
        elif owned is not None:
            self.states.setdefault(owned[0], []).append(StateReport.from_message(message, owned[0]))
        elif topic in EVENT_TOPICS:  # every event read before any is kept: a record is taken whole or not at all
            for event in [LinkEvent.from_message(item) for item in logged_events(topic, message)]:
                self.link_events.setdefault((event.sender, event.receiver), []).append(event)
        elif topic == META_KEY:
            self.meta = RunMeta.from_message(message)
        elif topic == FAULT_KEY:
            self.fault_events.append(FaultEvent.from_message(message))
        elif topic == GRAPH_KEY:
            graph = Graph.from_message(message)
            self.graph_changes.append((graph.t, list(graph.edges)))
        elif topic == COMMS_STATS_KEY:
            self.stats.append(CommsStats.from_message(message))


class Collector(Protocol):
    """Another reader of the same pass over a log (analysis.tables): the topics it wants, and each of their messages
    (ValueError for one that does not read)."""

    def wanted(self, topic: str) -> bool: ...

    def add(self, topic: str, message: dict[str, Any]) -> None: ...


@dataclass(frozen=True, slots=True)
class Together:
    """Several other readers of the same pass as one Collector: each handed the messages it wants."""

    readers: tuple[Collector, ...]

    def wanted(self, topic: str) -> bool:
        return any(reader.wanted(topic) for reader in self.readers)

    def add(self, topic: str, message: dict[str, Any]) -> None:
        for reader in self.readers:
            if reader.wanted(topic):
                reader.add(topic, message)


def read_for_report(path: Path) -> tuple[RunData, BooksLog]:
    """The run and its transmission books (supervisor.analysis.tx_books), in one pass over the log: what cpf report
    reads."""
    from supervisor.analysis.tx_books import BooksLog

    books = BooksLog()
    return load_run(path, also=books), books


def load_run(path: Path, also: Collector | None = None) -> RunData:
    """Read a run's MCAP into arrays; LogError (pointing to `cpf recover`) for a log cut short or damaged; a record
    that does not read named (a warning) and skipped (supervisor.record.unusable), but a meta that does not read is a
    ScenarioError naming the field. also: handed the messages it wants in the same pass (one read of the log)."""
    got, unusable = _Collected(), Unusable(path)
    wanted = _wanted if also is None else lambda topic: _wanted(topic) or also.wanted(topic)
    # checked whole: damage anywhere refuses the log, also in chunks the report skips (its Foxglove scene)
    for topic, _, message in logfile.read_checked(path, wanted):
        try:
            if _wanted(topic):
                got.add(topic, message)
            if also is not None and also.wanted(topic):
                also.add(topic, message)
        except ValueError as exc:  # named and skipped: one record a reading cannot use is not the whole log
            if topic == META_KEY:  # ... but the meta is: without it the run's duration, step and faults are unknown
                raise ScenarioError(f"{path}: {topic}: {exc}") from None
            unusable.skip(topic, exc)
    unusable.close()
    if got.empty():  # another tool's log, or a cut one recovered to nothing: empty figures and tables, exit 0, before
        raise LogError(f"{path}: holds no record of a cpf run (no cpf/ message): not a cpf log")
    vehicles = {v: _series(v, got.states[v]) for v in sorted(got.states)}
    start, end = _time_range(vehicles, got.meta)
    events = got.fault_events
    faults = _intervals_from_events(events, start, end) if events else _intervals_from_meta(got.meta, end)
    edges = [] if got.meta is None else list(got.meta.edges)
    return RunData(
        got.meta, vehicles, faults, edges, got.graph_changes,
        {link: _link_log(link, got.link_events[link]) for link in sorted(got.link_events)},
        got.stats, _estimate_ages(got.states), got.dones.drops(got.meta),
    )  # fmt: skip


def _link_log(link: Edge, events: list[LinkEvent]) -> LinkLog:
    delays = [np.nan if e.delay is None else e.delay for e in events]
    return LinkLog(
        link[0], link[1],
        np.array([e.t for e in events], dtype=float),
        np.array([e.kind for e in events], dtype=str),
        np.array(delays, dtype=float),
        np.array([e.reason or "" for e in events], dtype=str),
    )  # fmt: skip


def _estimate_ages(states: dict[int, list[StateReport]]) -> dict[Edge, AgeSeries]:
    """(neighbour, holder) -> ages, from the estimate_age field of every state report."""
    rows: dict[Edge, tuple[list[float], list[float]]] = {}
    for holder, reports in states.items():
        for m in reports:
            for held in m.estimate_age:
                t, ages = rows.setdefault((held.vehicle, holder), ([], []))
                age = held.age
                t.append(m.t)
                ages.append(age)
    return {key: AgeSeries(np.array(t, dtype=float), np.array(a, dtype=float)) for key, (t, a) in sorted(rows.items())}


def _series(vehicle: int, messages: list[StateReport]) -> VehicleSeries:
    def column(name: str) -> Array:
        return np.array([getattr(m, name) for m in messages], dtype=float)

    return VehicleSeries(
        vehicle=vehicle,
        t=column("t"),
        gamma=column("gamma"),
        gamma_dot=column("gamma_dot"),
        position=_matrix([m.position for m in messages], 3),
        velocity=_matrix([m.velocity for m in messages], 3),
        error=_matrix([m.error for m in messages], 3),
        tau=_matrix([m.tau for m in messages]),
        correction=column("correction"),
        lyapunov=column("lyapunov"),
        **_navigation(messages),
        current_estimate=_current_estimate(messages),
    )


def _current_estimate(messages: list[StateReport]) -> Array | None:
    """The observer's estimates, if every message has one, else None."""
    if not messages or any(m.current_estimate is None for m in messages):
        return None
    return _matrix([m.current_estimate or (math.nan,) * 3 for m in messages], 3)


def _navigation(messages: list[StateReport]) -> dict[str, Array]:
    """The navigation columns, if every message has an estimate (NaN-free), else none."""
    if not messages or any(m.nav_estimate is None for m in messages):
        return {}
    estimate = _matrix([m.estimated_position or (math.nan,) * 3 for m in messages], 3)
    sigma = _matrix([m.position_sigma or (math.nan,) * 3 for m in messages], 3)
    truth = _matrix([m.position for m in messages], 3)
    return {
        "nav_error": row_norms(estimate - truth),
        "nav_sigma": row_norms(sigma),
        "nav_fix": np.array([m.nav_fix or 0 for m in messages], dtype=int),
    }


def _matrix(rows: Sequence[Sequence[float]], width: int | None = None) -> Array:
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


def _fault_target(fields: dict[str, object]) -> str | None:
    """What a fault acts on: 'AUV 2', 'link 1->2' ('1<->2' both ways); None if fleet- or network-wide."""
    if fields.get("vehicle") is not None:
        return f"AUV {fields['vehicle']}"
    if fields.get("sender") is not None:
        return f"link {fields['sender']}{'<->' if fields.get('both') else '->'}{fields.get('receiver')}"
    return None


def _intervals_from_events(events: list[FaultEvent], run_start: float, run_end: float) -> list[FaultInterval]:
    """Pair start/end events per (kind, target); an open start runs to the end, an orphan end from t0."""
    open_faults: list[tuple[str, str | None, float]] = []
    intervals: list[FaultInterval] = []
    for event in events:
        kind, target, t = event.kind, _fault_target(event.detail), event.t
        if event.phase == "start":
            open_faults.append((kind, target, t))
            continue
        match = _find_open(open_faults, kind, target)
        start = run_start  # an end without a start: the fault was active from the beginning
        if match is not None:
            _, target, start = open_faults.pop(match)
        intervals.append(FaultInterval(kind, start, t, _fault_label(kind, target)))
    intervals += [FaultInterval(k, t, max(run_end, t), _fault_label(k, v)) for k, v, t in open_faults]
    return sorted(intervals, key=lambda f: (f.start, f.end))


def _find_open(open_faults: list[tuple[str, str | None, float]], kind: str, target: str | None) -> int | None:
    """Oldest open fault of this kind and target; an end event without a target closes any target's."""
    for k, (open_kind, open_target, _) in enumerate(open_faults):
        if open_kind == kind and (target is None or open_target == target):
            return k
    return None


def _intervals_from_meta(meta: RunMeta | None, run_end: float) -> list[FaultInterval]:
    """The scenario's planned faults, for runs that recorded no fault events."""
    intervals = []
    for fault in () if meta is None else meta.faults:
        kind, end = str(fault["kind"]), fault.get("end")
        end = run_end if end is None else float(end)
        intervals.append(FaultInterval(kind, float(fault["start"]), end, _fault_label(kind, _fault_target(fault))))
    return sorted(intervals, key=lambda f: (f.start, f.end))


# --- report ------------------------------------------------------------------------------------------------

"""A recorded run as pandas tables: one row per record of the log, every field of the record in its own column.

`read_run` reads a log once, in the pass the report's reader makes (analysis.rundata.load_run, over the one reader
of logs, supervisor.record.logfile: LogError for a log cut short or damaged), each message through its record type
(comms.records.state.StateReport, comms.records.records.Transmission, comms.records.receptions.RxBatch,
comms.records.records.LinkEvent, comms.records.run.FaultEvent: ScenarioError naming the topic for one that does not
read), and builds each table at once from lists of tuples. The Python API (`cpf.load`) and `cpf export` give these
tables; docs/api.md lists their columns and units.

- states: one row per vehicle and sync step (t, k, vehicle; position, velocity, error, tau, ... split per axis);
- transmissions: one row per packet a vehicle transmitted; receptions: one per packet a vehicle took in;
- link_events: one row per sent, delivered or dropped packet of a directed link (cpf/comms/events);
- faults: one row per fault starting or ending (its scenario fields in `detail`, JSON);
- metrics: one row per phase of the run (analysis.metrics: the numbers of metrics.json and `cpf run`'s summary).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec
import pandas as pd

from comms.records.events import EVENT_TOPICS, logged_events
from comms.records.messages import FAULT_KEY, vehicle_of_key
from comms.records.receptions import RxBatch
from comms.records.records import LinkEvent, Transmission
from comms.records.run import FaultEvent
from comms.records.state import StateReport
from supervisor.analysis.rundata import Collector, RunData, Together, load_run

__all__ = ["LOG_TABLES", "TABLES", "metrics_table", "read_run", "run_tables", "states_table"]

LOG_TABLES = ("states", "transmissions", "receptions", "link_events", "faults")  # what read_run gives
TABLES = (*LOG_TABLES, "metrics")  # and the one built from the run's metrics: what `cpf export` writes

AXES = ("x", "y", "z")  # inertial
BODY = ("u", "v", "w")  # body-frame linear velocity
RATES = ("p", "q", "r")  # body-frame angular velocity
NAV_STATE = ("nav_x", "nav_y", "nav_z", "nav_bias_u", "nav_bias_v", "nav_bias_w")  # the filter's estimate
NAV_COVARIANCE = tuple(f"nav_cov_{i}{j}" for i in range(6) for j in range(i, 6))  # its upper triangle by rows

TX_COLUMNS = ("t", "sender", "seq", "stamp", "gamma", "gamma_dot", *(f"position_{a}" for a in AXES),
              *(f"velocity_{a}" for a in AXES))  # fmt: skip
RX_COLUMNS = ("t", "k", "receiver", "sender", "seq", "stamp", "arrival", "gamma", "gamma_dot", "due")
EVENT_COLUMNS = ("t", "sender", "receiver", "seq", "kind", "delay", "reason")
FAULT_COLUMNS = ("t", "kind", "phase", "vehicle", "sender", "receiver", "start", "end", "detail")


@dataclass
class _Rows:
    """The rows of each table, as read (one tuple per row) and the widths of the variable-length state fields."""

    states: list[StateReport] = field(default_factory=list)
    transmissions: list[tuple[Any, ...]] = field(default_factory=list)
    receptions: list[tuple[Any, ...]] = field(default_factory=list)
    link_events: list[tuple[Any, ...]] = field(default_factory=list)
    faults: list[tuple[Any, ...]] = field(default_factory=list)

    def add(self, topic: str, message: dict[str, Any]) -> None:
        owned = vehicle_of_key(topic)
        if owned is not None:
            self._vehicle(owned[0], owned[1], message)
        elif topic in EVENT_TOPICS:  # every event read before any is kept: a record is taken whole or not at all
            events = [LinkEvent.from_message(item) for item in logged_events(topic, message)]
            self.link_events += [(e.t, e.sender, e.receiver, e.seq, e.kind, _nan(e.delay), e.reason) for e in events]
        elif topic == FAULT_KEY:
            self.faults.append(_fault_row(FaultEvent.from_message(message)))

    def wanted(self, topic: str) -> bool:
        owned = vehicle_of_key(topic)
        return (topic in EVENT_TOPICS or topic == FAULT_KEY) if owned is None else owned[1] in ("state", "tx", "rx")

    def _vehicle(self, vid: int, leaf: str, message: dict[str, Any]) -> None:
        if leaf == "state":
            self.states.append(StateReport.from_message(message, vid))
        elif leaf == "tx":
            x = Transmission.from_message(message, vid)
            self.transmissions.append((x.t, x.sender, x.seq, x.data_time, x.gamma, x.gamma_dot, *x.position,
                                       *x.velocity))  # fmt: skip
        elif leaf == "rx":
            b = RxBatch.from_message(message)
            self.receptions += [(b.t, b.k, b.vehicle, d.sender, d.seq, d.stamp, d.arrival, d.gamma, d.gamma_dot,
                                 _nan(d.due)) for d in b.receptions]  # fmt: skip


def _nan(value: float | None) -> float:
    return math.nan if value is None else value


def _fault_row(event: FaultEvent) -> tuple[Any, ...]:
    d = event.detail
    known = tuple(d.get(name) for name in ("vehicle", "sender", "receiver"))
    return (event.t, event.kind, event.phase, *known, d.get("start"), d.get("end"), json.dumps(d, sort_keys=True))


def read_run(path: Path, also: Collector | None = None) -> tuple[dict[str, pd.DataFrame], RunData]:
    """The log's tables (LOG_TABLES, each in log-time order, equal times in the order written) and the run as the
    report reads it (rundata.load_run), in one pass of the log (also: another reader of it, such as the report's
    books): LogError for a log that is missing, cut short or damaged, ScenarioError naming the topic for a record that
    does not read."""
    rows = _Rows()
    data = load_run(path, rows if also is None else Together((rows, also)))
    return _frames(rows), data


def _frames(rows: _Rows) -> dict[str, pd.DataFrame]:
    faults = pd.DataFrame.from_records(rows.faults, columns=list(FAULT_COLUMNS))
    for name in ("vehicle", "sender", "receiver"):  # ids, or none (a fleet- or network-wide fault)
        faults[name] = faults[name].astype("Int64")
    faults = faults.astype({"start": float, "end": float})  # end NaN: to the end of the run
    return {
        "states": states_table(rows.states),
        # In an order of the run's, not of the log's: each engine logs a step's vehicles in the order they came in
        # (a receiver's batch keeps the order it took them in: the sort is stable)
        "transmissions": _sorted(pd.DataFrame.from_records(rows.transmissions, columns=list(TX_COLUMNS)), "sender"),
        "receptions": _sorted(pd.DataFrame.from_records(rows.receptions, columns=list(RX_COLUMNS)), "receiver"),
        "link_events": pd.DataFrame.from_records(rows.link_events, columns=list(EVENT_COLUMNS)),
        "faults": faults,
    }


def _sorted(table: pd.DataFrame, by: str) -> pd.DataFrame:
    return table.sort_values(["t", by], kind="stable", ignore_index=True)


# --- states ---------------------------------------------------------------------------------------------------

Columns = list[tuple[tuple[str, ...], Callable[[StateReport], Sequence[Any]]]]  # (names, a report's values of them)


def states_table(reports: Sequence[StateReport]) -> pd.DataFrame:
    """One row per report, sorted by (k, vehicle); the columns of `_state_columns`."""
    columns = _state_columns(reports)
    names = [name for names, _ in columns for name in names]
    records = [tuple(value for _, values in columns for value in values(r)) for r in reports]
    table = pd.DataFrame.from_records(records, columns=names)
    return table.sort_values(["k", "vehicle"], kind="stable", ignore_index=True)


def _state_columns(reports: Sequence[StateReport]) -> Columns:
    """(column names, the values of a report for them), for every field of the state record; the variable-length
    fields get as many columns as the longest has (NaN-padded), the optional ones columns only if a report has them."""
    taus = max((len(r.tau) for r in reports), default=0)
    neighbours = sorted({held.vehicle for r in reports for held in r.estimate_age})
    columns: Columns = [
        (("t", "k", "vehicle", "gamma", "gamma_dot"), lambda r: (r.t, r.k, r.vehicle, r.gamma, r.gamma_dot)),
        (tuple(f"position_{a}" for a in AXES), lambda r: r.position),
        (tuple(f"rotation_{i}{j}" for i in range(3) for j in range(3)), lambda r: r.rotation),
        (tuple(f"velocity_{a}" for a in BODY), lambda r: r.velocity),
        (tuple(f"angular_velocity_{a}" for a in RATES), lambda r: r.angular_velocity),
        (tuple(f"error_{a}" for a in AXES), lambda r: r.error),
        (("path_error",), lambda r: (math.hypot(*r.error),)),
        (tuple(f"tau_{i}" for i in range(taus)), lambda r: _padded(r.tau, taus)),
        (("correction", "lyapunov", "tx_seq"), lambda r: (r.correction, r.lyapunov, r.tx_seq)),
        (tuple(f"estimate_age_{j}" for j in neighbours), lambda r: _ages(r, neighbours)),
    ]
    return columns + _optional_columns(reports) + _further_columns(reports)


def _optional_columns(reports: Sequence[StateReport]) -> Columns:
    """The realtime, navigation and current-observer columns, if any report has them."""
    columns: Columns = []
    if any(r.rx_lateness is not None for r in reports):
        columns.append((("rx_lateness_max",), lambda r: (max(r.rx_lateness or (), default=math.nan),)))
    if any(r.step_lateness is not None for r in reports):
        columns.append((("step_lateness",), lambda r: (_nan(r.step_lateness),)))
    if any(r.nav_estimate is not None for r in reports):
        width = len(NAV_STATE) + len(NAV_COVARIANCE)
        columns.append(((*NAV_STATE, *NAV_COVARIANCE), lambda r: _padded(r.nav_estimate or (), width)))
        columns.append((("nav_fix",), lambda r: (-1 if r.nav_fix is None else r.nav_fix,)))
    if any(r.current_estimate is not None for r in reports):
        names = tuple(f"current_estimate_{a}" for a in AXES)
        columns.append((names, lambda r: _padded(r.current_estimate or (), 3)))
    return columns


# The fields the columns above spell out; any other (one added to comms.records.state.StateReport since) gets
# columns of its own by _further_columns, so that adding a field to the state message is one edit.
_SPELT_OUT = frozenset({"t", "k", "vehicle", "gamma", "gamma_dot", "position", "rotation", "velocity",
                        "angular_velocity", "error", "tau", "correction", "lyapunov", "tx_seq", "estimate_age",
                        "rx_lateness", "step_lateness", "nav_estimate", "nav_fix", "current_estimate"})  # fmt: skip


def _further_columns(reports: Sequence[StateReport]) -> Columns:
    """A column for each other field a report has: its name for a number, name_i for each item of a tuple
    (NaN where a report lacks it)."""
    columns: Columns = []
    kind = type(reports[0]) if reports else StateReport
    for name in (f.name for f in msgspec.structs.fields(kind) if f.name not in _SPELT_OUT):
        present = [value for r in reports if (value := getattr(r, name)) is not None]
        if not present:
            continue
        if isinstance(present[0], tuple):
            width = max(len(value) for value in present)
            names = tuple(f"{name}_{i}" for i in range(width))
            columns.append((names, lambda r, n=name, w=width: _padded(getattr(r, n) or (), w)))  # type: ignore[misc]
        else:
            columns.append(((name,), lambda r, n=name: (_nan(getattr(r, n)),)))  # type: ignore[misc]
    return columns


def _padded(values: Sequence[float], width: int) -> tuple[float, ...]:
    return (*values[:width], *(math.nan,) * (width - len(values)))


def _ages(report: StateReport, neighbours: Sequence[int]) -> tuple[float, ...]:
    held = {a.vehicle: a.age for a in report.estimate_age}
    return tuple(held.get(j, math.nan) for j in neighbours)


# --- metrics --------------------------------------------------------------------------------------------------


def metrics_table(metrics: dict[str, Any]) -> pd.DataFrame:
    """One row per phase of analysis.metrics.run_metrics (metrics.json's coordination.phases): its name and span, the
    peak and final coordination error, the peak path-following error after the transient, and each vehicle's mean
    gamma_dot (mean_gamma_dot_<id>). Empty for a run without states."""
    phases = metrics.get("coordination", {}).get("phases", [])
    rows = [_phase_row(p) for p in phases]
    columns = ["name", "start", "end", "max_coordination_error", "final_coordination_error", "max_path_error"]
    rates = [c for c in (rows[0] if rows else {}) if c not in columns]
    table = pd.DataFrame.from_records(rows, columns=columns + rates)
    return table.rename(columns={"name": "phase"}).astype({c: float for c in columns[1:]})


def _phase_row(phase: dict[str, Any]) -> dict[str, Any]:
    rates = {f"mean_gamma_dot_{vid}": rate for vid, rate in phase["mean_gamma_dot"].items()}
    return {**{k: v for k, v in phase.items() if k != "mean_gamma_dot"}, **rates}


def run_tables(path: Path) -> dict[str, pd.DataFrame]:
    """Every table of a recorded run (TABLES): the log's, and its metrics per phase (the numbers of `cpf report`'s
    metrics.json, analysis.metrics)."""
    from supervisor.analysis.metrics import run_metrics

    tables, data = read_run(path)
    return {**tables, "metrics": metrics_table(run_metrics(data))}

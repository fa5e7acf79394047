"""What a recorded run is, in a few lines (`describe`), whether or not its writer finished the log.

A finished log ends with a summary (statistics, channels, chunk index): `describe` takes the message counts and the
time span from it and decodes only the run's meta message (and checks every chunk's CRC). A log whose writer was
killed has no summary: it is read linearly, record by record, up to the first record the file cuts short
(supervisor.record.logfile.read_raw); such a log is described as far as it goes, marked CUT SHORT, and `overview` also
returns the error the other commands give for it (`cpf info` prints the description, then fails with that error).
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import IO

from mcap.records import Statistics
from mcap.summary import Summary

from comms.records.messages import META_KEY
from supervisor.analysis.condense import MAX_ROWS, SHOWN
from supervisor.config.describe import describe_fault, seconds
from supervisor.record.logfile import (
    LogError,
    RawLog,
    RawMessage,
    damaged,
    lenient_summary,
    open_log,
    reader_of,
    scan,
    verify,
)
from supervisor.record.meta import RunMeta

__all__ = ["LogError", "describe", "overview"]

TOPIC_WIDTH = 28


# --- describing ---------------------------------------------------------------------------------------------


def describe(path: Path) -> str:
    """A short multi-line summary of a log: what ran, how long, which faults, and the message count per topic."""
    return overview(path)[0]


def overview(path: Path) -> tuple[str, LogError | None]:
    """describe's text, and the error a strict reader (record.logfile) meets in the log: None if it is whole."""
    log, source, problem = _overview(path)
    meta = _meta(log)
    lines = [
        f"{path}: {_size(path.stat().st_size)}, {sum(log.counts.values())} messages on {len(log.counts)} topics "
        f"({source})",
        *_run_lines(meta, log),
        "topics" if log.counts else "topics     none",
        *topic_lines(log.counts),
    ]
    return "\n".join(lines), problem


def topic_lines(counts: dict[str, int]) -> list[str]:
    """A line per topic with its message count; topics alike but for a vehicle's number (cpf/vehicle/<id>/state),
    more than MAX_ROWS of them, as one line: how many, their messages in all and each's least and most (1000 AUVs
    made 5000 lines)."""
    alike: dict[str, list[str]] = {}
    for topic in sorted(counts):
        alike.setdefault(re.sub(r"(?<=/)\d+(?=/|$)", "<id>", topic), []).append(topic)
    lines = []
    for pattern, topics in sorted(alike.items()):
        if len(topics) <= MAX_ROWS:
            lines += [f"  {topic:<{TOPIC_WIDTH}}{counts[topic]:>8}" for topic in topics]
        else:
            each = [counts[topic] for topic in topics]
            lines.append(
                f"  {pattern:<{TOPIC_WIDTH}}{sum(each):>8}  ({len(topics)} topics, {min(each)}-{max(each)} each)"
            )
    return lines


def _overview(path: Path) -> tuple[RawLog, str, LogError | None]:
    """Counts and time span from the summary when there is one (decoding only the meta), else from reading; and
    what is wrong with the log, if anything (every chunk is checked: a damaged one is no less damaged for being
    counted in the summary)."""
    with open_log(path) as stream:
        summary = lenient_summary(stream)
        if summary is not None and summary.statistics is not None:
            log, source = _from_summary(stream, summary, summary.statistics), "counts from the file's summary"
        else:
            log = scan(stream, lambda topic: topic == META_KEY)
            source = "no statistics in the file: counted by reading it"
    if summary is None and not log.complete:
        cut = "CUT SHORT, no summary: counted what is readable; `cpf recover` rebuilds it"
        return log, cut, damaged(path, "no footer at its end, its writer did not finish it")
    try:
        verify(path)
    except LogError as exc:
        return log, f"{source}; DAMAGED: `cpf recover` keeps what is readable", exc
    return log, source, None


def _from_summary(stream: IO[bytes], summary: Summary, stats: Statistics) -> RawLog:
    """The summary's message counts and time span, and the meta message (read through the chunk index)."""
    log = RawLog()
    if stats.message_count:
        log.first_time, log.last_time = stats.message_start_time, stats.message_end_time
    for channel_id, count in stats.channel_message_counts.items():
        log.counts[summary.channels[channel_id].topic] += count
    try:
        for _, _, message in reader_of(stream).iter_messages(topics=[META_KEY]):
            log.messages.append(RawMessage(META_KEY, message.log_time, message.data))
            break
    except Exception:  # a damaged chunk (any error type): described without its meta, verify() reports it
        pass
    return log


def _meta(log: RawLog) -> RunMeta | str:
    """The run's metadata, read through its record, or why there is none to describe."""
    for message in log.messages:
        if message.topic == META_KEY:
            try:
                return RunMeta.from_message(json.loads(message.data))
            except ValueError as exc:  # JSON, or the record's own check (json.JSONDecodeError is a ValueError)
                return f"run        cpf/run/meta does not read ({exc})"
    return "run        no cpf/run/meta message: not a cpf run, or cut before it"


def _run_lines(meta: RunMeta | str, log: RawLog) -> list[str]:
    if isinstance(meta, str):
        return [meta]
    faults = [describe_fault(f, meta.step) for f in meta.faults] or ["none"]
    description = meta.scenario.get("scenario", {}).get("description")
    return [
        f"scenario   {meta.scenario_name} ({meta.scenario_file})",
        *([f"           {description}"] if description else []),
        f"engine     {meta.engine}, clock {meta.clock}, seed {meta.seed}, step {meta.step} s",
        f"versions   {', '.join(f'{name} {version}' for name, version in sorted(meta.versions.items())) or '-'}",
        *(f"{'extensions' if i == 0 else '':<11}{text}" for i, text in enumerate(meta.extensions)),
        f"duration   {seconds(meta.duration)} s simulated (scenario); messages from t = "
        f"{seconds(_ns(log.first_time))} to {seconds(_ns(log.last_time))} s",
        f"vehicles   {_vehicles(meta)}",
        f"graph      {_edges(meta.edges)}",
        f"faults     {faults[0]}",
        *(f"           {line}" for line in faults[1:]),
        *_plant_lines(meta),
    ]


def _vehicles(meta: RunMeta) -> str:
    """Each vehicle with the model or preset it flew ("1, 2, 3 (each remus100)" when all fly the same), from the
    scenario the log holds; the bare ids for a log whose scenario this version does not read."""
    from pydantic import ValidationError

    from supervisor.config.scenario_schema import Scenario
    from supervisor.config.vehicle_models import model_name_of

    ids = _ids(meta.vehicles) or "-"
    try:
        scenario = Scenario.model_validate(meta.scenario)
        names = [model_name_of(scenario, v) for v in meta.vehicles]
    except (ValidationError, StopIteration):  # another version's scenario, or ids it does not hold
        return ids
    if len(set(names)) == 1:
        return f"{ids} (each {names[0]})"
    if len(names) > MAX_ROWS:  # by model: "remus100: 1-500; own: 501-1000"
        by: dict[str, list[int]] = {}
        for v, name in zip(meta.vehicles, names, strict=True):
            by.setdefault(name, []).append(v)
        return "; ".join(f"{name}: {_ids(vs)}" for name, vs in by.items())
    return ", ".join(f"{v} {name}" for v, name in zip(meta.vehicles, names, strict=True))


def _ids(ids: Sequence[int]) -> str:
    """Vehicle ids as listed; more than MAX_ROWS, runs of consecutive ones as ranges (1000 AUVs: '1-1000')."""
    if len(ids) <= MAX_ROWS:
        return ", ".join(str(v) for v in ids)
    runs: list[list[int]] = []
    for v in ids:
        if runs and v == runs[-1][-1] + 1:
            runs[-1].append(v)
        else:
            runs.append([v])
    return ", ".join(f"{r[0]}-{r[-1]}" if len(r) > 2 else ", ".join(map(str, r)) for r in runs)


def _edges(edges: Sequence[Sequence[int]]) -> str:
    """The graph's edges; more than MAX_ROWS, how many and the first and last few."""
    named = [f"{i}-{j}" for i, j in edges]
    if len(named) <= MAX_ROWS:
        return ", ".join(named) or "-"
    return f"{len(named)} edges: {', '.join(named[: SHOWN // 2])}, ..., {', '.join(named[-2:])}"


def _plant_lines(meta: RunMeta) -> list[str]:
    """The current and each vehicle's drawn plant (supervisor.config.plant), from the scenario the log holds."""
    from pydantic import ValidationError

    from supervisor.config.plant import describe_plant
    from supervisor.config.scenario_schema import Scenario

    try:
        return describe_plant(Scenario.model_validate(meta.scenario), meta.seed)
    except ValidationError:  # a log of another version: its scenario is described above, its plant not
        return []


def _ns(value: int | None) -> float | None:
    return None if value is None else value / 1e9


def _size(size: int) -> str:
    value, unit = float(size), "B"
    for unit in ("B", "kB", "MB", "GB"):
        if value < 1000 or unit == "GB":
            break
        value /= 1000
    return f"{size} B" if unit == "B" else f"{value:.1f} {unit} ({size} bytes)"

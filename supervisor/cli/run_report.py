"""What `cpf run` tells of a finished run: the summary it prints (headline, phases, links, timing) and the file
--metrics writes. cpf.run writes the same file (write_metrics) and prints nothing."""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from supervisor.analysis.comms_summary import CommsSummary
    from supervisor.analysis.divergence import Divergence
    from supervisor.analysis.summary import Summary
    from supervisor.config.scenario_schema import Scenario
    from supervisor.engine.inprocess import RunResult

log = logging.getLogger("cpf")


@dataclass(frozen=True, slots=True)
class RunNumbers:
    """What the printed summary and the metrics file are both made of."""

    summary: Summary
    comms: CommsSummary
    diverged: Divergence | None


def run_numbers(scenario: Scenario, result: RunResult) -> RunNumbers:
    """The run's summary per phase, per link, and whether its coordination loop diverged."""
    from supervisor.analysis.comms_summary import comms_summary
    from supervisor.analysis.divergence import divergence
    from supervisor.analysis.summary import phases_end, summarize
    from supervisor.config.derived import intervals, tube_radius

    rep, duration, tube = scenario.report, scenario.scenario.duration, tube_radius(scenario)
    end = phases_end(result.series.t, scenario.scenario.step, duration)  # a run stopped early: where its data ends
    summary = summarize(result.series, end, intervals(scenario), rep.transient, tube, rep.coordination_tolerance)
    comms = comms_summary(result.link_stats, result.stats_history, result.estimate_ages)
    return RunNumbers(summary, comms, divergence(result.series, scenario.coordination.v_r, rep.coordination_tolerance))


def report_run(args: argparse.Namespace, scenario: Scenario, result: RunResult, out: Path) -> None:
    """The run's headline, summary per phase and per link (and realtime timing) on stdout; --metrics as JSON."""
    from supervisor.analysis.comms_summary import format_comms, format_malformed
    from supervisor.analysis.saturation_summary import at_limit, format_limits
    from supervisor.analysis.summary import format_summary
    from supervisor.engine.realtime_timing import fell_behind, format_timing

    numbers, duration = run_numbers(scenario, result), scenario.scenario.duration
    if args.metrics:  # before the summary: a reader of stdout that leaves early (head) must not cost the file
        write_metrics(args.metrics, scenario, result, numbers)
    print(_headline(args, scenario, result, out))
    if args.clock == "realtime" and (behind := fell_behind(duration, result.stepping_time, args.speed or 1.0)):
        log.warning("%s", behind)
    lines = (
        format_summary(numbers.summary),
        _divergence_lines(args, scenario, numbers.diverged),
        format_limits(at_limit(scenario, result.series), duration),
        _input_lines(scenario, result),
        format_comms(numbers.comms),
        format_timing(result.realtime) if result.realtime is not None else None,
        format_malformed(result.malformed or {}, result.drop_causes or {}),
    )
    print("\n".join(line for line in lines if line is not None))


def _headline(args: argparse.Namespace, scenario: Scenario, result: RunResult, out: Path) -> str:
    duration = scenario.scenario.duration
    factor = duration / max(result.stepping_time, 1e-9)
    scene = f" (+{result.scene_messages} for Foxglove)" if result.scene_messages else ""
    return (
        f"{scenario.scenario.name}: {len(scenario.vehicles)} vehicles, {args.engine} engine, "
        f"{duration:g} s simulated in {result.wall_time:.2f} s "
        f"(stepping {result.stepping_time:.2f} s, {factor:.{0 if factor >= 10 else 2}f}x real time), "
        f"{result.messages} messages{scene} -> {out}"
    )


def _divergence_lines(args: argparse.Namespace, scenario: Scenario, found: Divergence | None) -> str | None:
    """What the summary says of a diverged loop, with the stability analysis's verdict on the scenario (issue 23)."""
    from supervisor.analysis.divergence import format_divergence
    from supervisor.config.links import unmodelled
    from supervisor.config.stability.scenario import predicted_change

    if found is None:
        return None
    predicted = predicted_change(scenario)
    return format_divergence(found, scenario.coordination.v_r, predicted, str(args.scenario), unmodelled(scenario))


def _input_lines(scenario: Scenario, result: RunResult) -> str | None:
    """The summary's lines on inputs at their limits (supervisor.analysis.input_limits)."""
    from supervisor.analysis.input_limits import at_input_limits, format_input_limits

    return format_input_limits(at_input_limits(scenario, result.series))


def write_metrics(path: Path, scenario: Scenario, result: RunResult, numbers: RunNumbers | None = None) -> None:
    """--metrics: the summary's numbers (numbers: run_numbers's, found here if not given), the links' counts, the
    drops, the inputs at their limits, the realtime timing."""
    from supervisor.analysis.divergence import as_metric
    from supervisor.analysis.input_limits import at_input_limits, input_limits_metrics
    from supervisor.analysis.metrics import finite

    numbers = numbers or run_numbers(scenario, result)
    metrics: dict[str, Any] = {"coordination": numbers.summary.as_dict(), "comms": numbers.comms.as_dict()}
    metrics["divergence"] = as_metric(numbers.diverged)
    path.parent.mkdir(parents=True, exist_ok=True)
    metrics["links"] = result.link_counts
    if result.realtime is not None:
        metrics["realtime"] = result.realtime
    # reader -> key (cause) -> messages it dropped; in process there is no bus, no reader, nothing dropped: the same
    # keys all the same, so that both engines' files read alike (a new user diffed them)
    metrics["malformed"] = result.malformed or {}
    metrics["dropped_by_cause"] = result.drop_causes or {}
    metrics |= input_limits_metrics(at_input_limits(scenario, result.series))
    try:
        path.write_text(json.dumps(finite(metrics), indent=2, allow_nan=False))
    except OSError as exc:  # a full disk: no half-written file left, and the error (at main) names it
        with contextlib.suppress(OSError):
            if path.is_file():  # never a device (/dev/full): root may unlink one
                path.unlink()
        raise OSError(exc.errno, exc.strerror, str(path)) from None

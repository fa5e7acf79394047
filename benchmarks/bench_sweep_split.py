"""Where a sweep run's CPU goes: `.venv/bin/python -m benchmarks.bench_sweep_split [--scenario S] [--repeat N]`.

One run of a sweep (supervisor.tools.sweep.run_one: the in-process engine, nothing recorded, its metrics row), timed
by the process's CPU, best of --repeat: whole, then again with every vehicle step handed back from a recording of
the same run (vehicles.step.node_step replaced by its recorded outputs, in order). The second leaves everything else
the engine does: the plan of each step, the channel and its books, the messages, the series, the summary. The
difference is what the vehicles' own steps cost. The row of the replayed run must equal the whole run's (checked:
the replay is the same run, not a cheaper one).

From the rest it prints the least time a 1000-run sweep could take on this machine's cores with a vehicle step that
cost nothing (rest x 1000 / cores): issue 26 asks for 2 min, so if that floor is above it, no compiled or vectorised
vehicle step alone reaches the target; only running the whole engine cheaper per run (many runs as arrays) can.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import vehicles.step
from benchmarks import ROOT, save
from supervisor.tools.sweep import RunSpec, run_one

SWEEP_RUNS = 1000  # issue 26: a 1000-run paper sweep in <= 2 min
TARGET_S = 120.0


def measure(scenario: Path, repeat: int, duration: float | None = None) -> dict[str, Any]:
    """CPU s of one sweep run, whole and with the vehicle steps replayed (best and spread of repeat each)."""
    spec = RunSpec((("scenario.duration", duration),) if duration else (), 0)
    text = scenario.read_bytes()

    def run() -> dict[str, Any]:
        return run_one(scenario.name, text, spec, "inprocess")

    outputs: list[Any] = []
    expected = _recording(run, outputs)
    whole = [_cpu(run)[0] for _ in range(repeat)]
    rest: list[float] = []
    for _ in range(repeat):
        handed = iter(outputs)
        seconds, row = _cpu(lambda: _replaying(run, handed))  # noqa: B023  # called here, in this iteration
        if _without_wall(row) != _without_wall(expected):
            raise AssertionError(f"the replayed run's row differs from the run's: {row} != {expected}")
        if next(handed, None) is not None:  # else the run stepped its vehicles itself: nothing was left out
            raise AssertionError("the replayed run did not take every recorded vehicle step")
        rest.append(seconds)
    cores = os.cpu_count() or 1
    return {
        "scenario": scenario.name, "duration": duration, "repeat": repeat, "cores": cores,
        "whole_cpu_s": min(whole), "whole_spread_s": _spread(whole),
        "rest_cpu_s": min(rest), "rest_spread_s": _spread(rest),
        "vehicle_steps_cpu_s": min(whole) - min(rest), "vehicle_steps": len(outputs),
        "sweep_floor_s": min(rest) * SWEEP_RUNS / cores, "sweep_now_s": min(whole) * SWEEP_RUNS / cores,
    }  # fmt: skip


def _recording(run: Callable[[], dict[str, Any]], into: list[Any]) -> dict[str, Any]:
    """The run, with every node_step output kept in order (warms the caches too)."""
    real = vehicles.step.node_step

    def keep(*args: Any) -> Any:
        out = real(*args)
        into.append(out)
        return out

    vehicles.step.node_step = keep  # type: ignore[assignment]  # the same call, its outputs kept
    try:
        return run()
    finally:
        vehicles.step.node_step = real


def _replaying(run: Callable[[], dict[str, Any]], outputs: Iterator[Any]) -> dict[str, Any]:
    real = vehicles.step.node_step
    vehicles.step.node_step = lambda *_: next(outputs)
    try:
        return run()
    finally:
        vehicles.step.node_step = real


def _cpu(call: Callable[[], Any]) -> tuple[float, Any]:
    began = time.process_time()
    out = call()
    return time.process_time() - began, out


def _without_wall(row: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in row.items() if k != "wall_s"}


def _spread(values: list[float]) -> float:
    return max(values) - min(values) if len(values) > 1 else 0.0


def summary(r: dict[str, Any]) -> str:
    share = r["vehicle_steps_cpu_s"] / r["whole_cpu_s"]
    return (
        f"sweep run of {r['scenario']} (in-process, best of {r['repeat']}, CPU): whole {r['whole_cpu_s']:.2f} s "
        f"(spread {r['whole_spread_s']:.2f}); without its vehicle steps {r['rest_cpu_s']:.2f} s "
        f"(spread {r['rest_spread_s']:.2f}): the vehicles' {r['vehicle_steps']} steps are {share:.0%}\n"
        f"  {SWEEP_RUNS} runs on {r['cores']} cores: {r['sweep_now_s'] / 60:.1f} min now; at least "
        f"{r['sweep_floor_s'] / 60:.1f} min with a vehicle step that cost nothing (issue 26's target "
        f"{TARGET_S / 60:.0f} min)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    result = measure(args.scenario, args.repeat)
    print(summary(result))
    print(f"written: {save('sweep_split', result)}")


if __name__ == "__main__":
    main()

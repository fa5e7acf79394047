"""Realtime delivery accuracy: `.venv/bin/python -m benchmarks.bench_realtime [--duration 60] [--speed 1]`.

Runs a scenario (default the paper's, first --duration simulated seconds) with the Zenoh engine on the realtime
clock. The broker sends each reception as soon as the channel has decided it, stamped with the wall-clock time of
its computed arrival; the vehicle holds it until then. Each vehicle process notes when every delivery reached it
against its arrival, and its state messages carry those numbers (`rx_lateness`, negative when it came ahead).
The delivery error is how late a reception was available to its vehicle: max(0, reached - arrival). Prints its
p50 / p99 / max, how far ahead the deliveries came (the margin the bus left), how many receptions were taken in a
step later than their arrival called for, and how late the vehicles began their steps against the wall clock
(`step_lateness`); writes benchmarks/results/realtime.json.
"""

from __future__ import annotations

import argparse
import io
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from comms.channel import intake_step
from supervisor.cosim import BusOptions, run_zenoh
from supervisor.progress import Progress
from supervisor.recorder import read_messages
from supervisor.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


def lateness(log: Path, dt: float) -> dict[str, Any]:
    """Delivery error (ms) from the vehicles' state messages, and receptions taken in later than lockstep would."""
    late: list[float] = []
    step_late: list[float] = []
    receptions = taken_late = 0
    for topic, _, message in read_messages(log):
        if topic.endswith("/state"):
            late += message.get("rx_lateness", [])
            step_late.append(message.get("step_lateness", np.nan))
        elif topic.endswith("/rx"):
            for r in message["receptions"]:
                receptions += 1
                taken_late += message["k"] > intake_step(r["arrival"], dt)
    reached = np.array(late) * 1e3  # ms after the arrival; negative: ahead of it
    error = np.maximum(reached, 0.0)  # a reception that came ahead is held until its arrival: no error
    percentiles = {f"p{p}_ms": float(np.percentile(error, p)) for p in (50, 90, 99)} if len(error) else {}
    return {
        "deliveries": len(error),
        **percentiles,
        "max_ms": float(error.max()) if len(error) else None,
        "ahead_share": float(np.mean(reached <= 0.0)) if len(reached) else None,
        "ahead_p50_ms": float(np.percentile(-reached, 50)) if len(reached) else None,
        "receptions": receptions,
        "taken_in_a_step_late": taken_late,
        "step_lateness_p50_ms": float(np.nanpercentile(step_late, 50) * 1e3) if step_late else None,
        "step_lateness_p99_ms": float(np.nanpercentile(step_late, 99) * 1e3) if step_late else None,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    parser.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall-clock second")
    args = parser.parse_args()
    result = measure(args.scenario, args.duration, args.speed)
    print(summary(result))
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "realtime.json").write_text(json.dumps(result, indent=2))


def measure(scenario_path: Path, duration: float, speed: float) -> dict[str, Any]:
    overrides = (f"scenario.duration={duration}",)
    scenario = load_scenario(scenario_path, overrides)
    text = scenario_path.read_text()
    with tempfile.TemporaryDirectory(prefix="cpf-realtime-") as tmp:
        log = Path(tmp) / "run.mcap"
        quiet = Progress(duration, io.StringIO(), enabled=False)
        bus = BusOptions(overrides=overrides)
        run_zenoh(scenario, scenario_path, text, log, 0, "realtime", speed, bus, quiet)
        return {"scenario": str(scenario_path), "duration_s": duration, "speed": speed,
                **lateness(log, scenario.scenario.step)}  # fmt: skip


def summary(result: dict[str, Any]) -> str:
    if not result["deliveries"]:
        return "realtime: no deliveries"
    return (
        f"realtime at --speed {result['speed']:g}: {result['deliveries']} deliveries, delivery error p50 "
        f"{result['p50_ms']:.2f} ms, p99 {result['p99_ms']:.2f} ms, max {result['max_ms']:.2f} ms; "
        f"{result['ahead_share']:.1%} reached their vehicle ahead of arrival (median {result['ahead_p50_ms']:.1f} ms "
        f"ahead); {result['taken_in_a_step_late']} of {result['receptions']} receptions taken in a step late; "
        f"vehicles began their steps {result['step_lateness_p50_ms']:.2f} ms (p50) / "
        f"{result['step_lateness_p99_ms']:.2f} ms (p99) after t_k"
    )


if __name__ == "__main__":
    main()

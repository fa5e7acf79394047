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
import tempfile
from pathlib import Path
from typing import Any

from benchmarks import ROOT, save
from supervisor.config.scenario import load_scenario
from supervisor.engine.cosim import BusOptions, run_zenoh
from supervisor.engine.progress import Progress
from supervisor.engine.realtime_timing import format_timing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    parser.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall-clock second")
    args = parser.parse_args()
    result = measure(args.scenario, args.duration, args.speed)
    print(summary(result))
    save("realtime", result)


def measure(scenario_path: Path, duration: float, speed: float) -> dict[str, Any]:
    overrides = (f"scenario.duration={duration}",)
    scenario = load_scenario(scenario_path, overrides)
    text = scenario_path.read_text()
    with tempfile.TemporaryDirectory(prefix="cpf-realtime-") as tmp:
        log = Path(tmp) / "run.mcap"
        quiet = Progress(duration, io.StringIO(), enabled=False)
        bus = BusOptions(overrides=overrides)
        result = run_zenoh(scenario, scenario_path, text, log, 0, "realtime", speed, bus, quiet)
    assert result.realtime is not None  # a realtime run always says how it kept to the wall clock
    return {"scenario": str(scenario_path), "duration_s": duration, "speed": speed, **result.realtime}


def summary(result: dict[str, Any]) -> str:
    return f"--speed {result['speed']:g}, {result['deliveries']} deliveries; {format_timing(result)}"


if __name__ == "__main__":
    main()

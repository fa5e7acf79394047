"""Wall time of a scenario with each engine: `.venv/bin/python -m benchmarks.bench_engines [--repeat N]`.

Prints one line per engine (best of N; the Zenoh engine's time includes starting its processes) and the ratio, and
writes them to benchmarks/results/engines.json. Targets (issue 7): the paper scenario at >= 100x real time, the
Zenoh engine at most 1.5x the in-process engine's wall time.
"""

from __future__ import annotations

import argparse
import io
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmarks import ROOT, save
from supervisor.config.scenario import load_scenario
from supervisor.engine.cosim import BusOptions, run_zenoh
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress


def best_of(repeat: int, run: Callable[[Path], object]) -> float:
    best = float("inf")
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            start = time.perf_counter()
            run(Path(tmp) / "run.mcap")
            best = min(best, time.perf_counter() - start)
    return best


def measure(path: Path, repeat: int) -> dict[str, Any]:
    scenario = load_scenario(path)
    text = path.read_text()
    duration = scenario.scenario.duration

    def quiet() -> Progress:
        return Progress(duration, io.StringIO(), enabled=False)

    walls = {
        "inprocess": best_of(repeat, lambda out: run_inprocess(scenario, str(path), text, out, 0, quiet())),
        "zenoh": best_of(
            repeat, lambda out: run_zenoh(scenario, path, text, out, 0, "lockstep", 1.0, BusOptions(), quiet())
        ),
    }
    results: dict[str, Any] = {"scenario": str(path), "duration_s": duration, "repeat": repeat}
    for engine, wall in walls.items():
        results[engine] = {"wall_s": wall, "real_time_factor": duration / wall}
    results["zenoh_over_inprocess"] = walls["zenoh"] / walls["inprocess"]
    return results


def summary(results: dict[str, Any]) -> str:
    lines = [
        f"{engine:<10} {results[engine]['wall_s']:7.2f} s   {results[engine]['real_time_factor']:6.1f}x real time"
        for engine in ("inprocess", "zenoh")
    ]
    lines.append(f"zenoh / inprocess wall time: {results['zenoh_over_inprocess']:.2f}   (targets: >= 100x, <= 1.5)")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    results = measure(args.scenario, args.repeat)
    print(summary(results))
    save("engines", results)


if __name__ == "__main__":
    main()

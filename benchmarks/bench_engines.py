"""Wall time of a scenario with each engine: `.venv/bin/python -m benchmarks.bench_engines [--repeat N]`.

Prints one line per engine (best of N, process start-up included for the Zenoh engine) and the ratio, and writes
them to benchmarks/results/engines.json. Speed targets are checked here, never by timed assertions in tests.
"""

from __future__ import annotations

import argparse
import io
import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from supervisor.cosim import BusOptions, run_zenoh
from supervisor.inprocess import run_inprocess
from supervisor.progress import Progress
from supervisor.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


def best_of(repeat: int, run: Callable[[Path], object]) -> float:
    best = float("inf")
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            start = time.perf_counter()
            run(Path(tmp) / "run.mcap")
            best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    text = args.scenario.read_text()
    duration = scenario.scenario.duration

    def quiet() -> Progress:
        return Progress(duration, io.StringIO(), enabled=False)

    walls = {
        "inprocess": best_of(
            args.repeat, lambda out: run_inprocess(scenario, str(args.scenario), text, out, 0, quiet())
        ),
        "zenoh": best_of(
            args.repeat,
            lambda out: run_zenoh(scenario, args.scenario, text, out, 0, "lockstep", 1.0, BusOptions(), quiet()),
        ),
    }
    results: dict[str, object] = {
        engine: {"wall_s": wall, "real_time_factor": duration / wall} for engine, wall in walls.items()
    }
    results["zenoh_over_inprocess"] = walls["zenoh"] / walls["inprocess"]
    for engine, wall in walls.items():
        print(f"{engine:<10} {wall:7.2f} s   {duration / wall:6.1f}x real time")
    print(f"zenoh / inprocess wall time: {walls['zenoh'] / walls['inprocess']:.2f}")
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "engines.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()

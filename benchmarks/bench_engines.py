"""Wall time of the paper scenario per engine: `python -m benchmarks.bench_engines [--repeat N]`.

Prints one line per engine with the best-of-N wall time and the real-time factor, and writes them as JSON to
benchmarks/results/engines.json. Speed targets are checked here, never by timed assertions in tests.
"""

from __future__ import annotations

import argparse
import io
import json
import tempfile
import time
from pathlib import Path

from supervisor.inprocess import run_inprocess
from supervisor.progress import Progress
from supervisor.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


def time_inprocess(scenario_path: Path, repeat: int) -> float:
    scenario = load_scenario(scenario_path)
    text = scenario_path.read_text()
    best = float("inf")
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
            start = time.perf_counter()
            run_inprocess(scenario, str(scenario_path), text, Path(tmp) / "run.mcap", 0, quiet)
            best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    duration = load_scenario(args.scenario).scenario.duration
    wall = time_inprocess(args.scenario, args.repeat)
    results = {"inprocess": {"wall_s": wall, "real_time_factor": duration / wall}}
    for engine, row in results.items():
        print(f"{engine:<10} {row['wall_s']:7.2f} s   {row['real_time_factor']:6.1f}x real time")
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "engines.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()

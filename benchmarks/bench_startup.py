"""How fast a fleet's processes start, forked or spawned: `.venv/bin/python -m benchmarks.bench_startup`.

N AUVs on parallel lines over a ring graph (bench_scaling.ring_scenario), one message per vehicle per second, one
process per AUV forced, run by the Zenoh engine with its children forked from the fork server
(supervisor.cli.fork_server) and, alternating in the same run, spawned (`cpf run --start spawn`, every child a fresh
interpreter): the start-up (from the call until the first step: the run's wall time less its stepping), the
real-time factor while stepping, and the peak resident memory of a vehicle process. Best of --repeat, spread
(max - min) beside. Issue 26's targets: 50 AUVs started in <= 1.5 s, >= 20x real time; a vehicle process <= 60 MB.
Written to benchmarks/results/startup.json.
"""

from __future__ import annotations

import argparse
import io
import tempfile
from pathlib import Path
from typing import Any

from benchmarks import save
from benchmarks.bench_scaling import ProcessSampler, ring_scenario
from supervisor.config.scenario import parse_scenario
from supervisor.engine.cosim import BusOptions, run_zenoh
from supervisor.engine.progress import Progress

STARTS = ("fork", "spawn")


def measure(n: int, duration: float, repeat: int) -> dict[str, Any]:
    text = ring_scenario(n, duration) + '\n[comms.transmit]\npolicy = "periodic"\nperiod = 1.0\n'
    runs: dict[str, list[dict[str, float]]] = {start: [] for start in STARTS}
    with tempfile.TemporaryDirectory(prefix=f"cpf-startup-{n}-") as tmp:
        path = Path(tmp) / f"ring{n}.toml"
        path.write_text(text)
        scenario = parse_scenario(text, str(path))
        for _ in range(repeat):
            for start in STARTS:  # alternating: the machine's drift hits both alike
                runs[start].append(_once(scenario, path, text, start, duration))
    row: dict[str, Any] = {"vehicles": n, "duration_s": duration}
    for start, rows in runs.items():
        row[start] = {key: _best(rows, key) for key in ("startup_s", "real_time_factor", "peak_rss_mb")}
    return row


def _once(scenario: Any, path: Path, text: str, start: str, duration: float) -> dict[str, float]:
    bus = BusOptions()
    bus.per_process, bus.fork = 1, start == "fork"
    quiet = Progress(duration, io.StringIO(), False)
    with ProcessSampler(str(path), len(scenario.vehicle_ids)) as sampler:
        result = run_zenoh(scenario, path, text, path.with_suffix(".mcap"), 0, "lockstep", 1.0, bus, quiet)
    return {
        "startup_s": result.wall_time - result.stepping_time,
        "real_time_factor": duration / result.stepping_time,
        "peak_rss_mb": max(sampler.rss.values(), default=0) / 2**20,
    }


def _best(rows: list[dict[str, float]], key: str) -> dict[str, float]:
    """The best of the runs (least start-up and memory, highest rate) and the spread."""
    values = [r[key] for r in rows]
    best = max(values) if key == "real_time_factor" else min(values)
    return {"best": best, "spread": max(values) - min(values)}


def summary(row: dict[str, Any]) -> str:
    def one(start: str) -> str:
        m = row[start]
        return (
            f"{start} start-up {m['startup_s']['best']:.2f} s (spread {m['startup_s']['spread']:.2f}), "
            f"{m['real_time_factor']['best']:.1f}x stepping, {m['peak_rss_mb']['best']:.0f} MB"
        )

    return f"N={row['vehicles']:3d} one process per AUV: {one('fork')}; {one('spawn')}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="10,50", help="fleet sizes, comma-separated")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds per run")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each start (best kept)")
    args = parser.parse_args()
    rows = []
    for n in (int(s) for s in args.sizes.split(",")):
        rows.append(measure(n, args.duration, args.repeat))
        print(summary(rows[-1]), flush=True)
    save("startup", rows)


if __name__ == "__main__":
    main()

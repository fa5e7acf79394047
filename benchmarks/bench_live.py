"""The live view's cost and latency (`cpf run --live`, supervisor/record/live.py; README, "Watching a run live").

Cost: the paper scenario as a whole `cpf run` command, each engine with and without `--live 0` (nobody connected),
alternating, best of N. Latency: a run with a client subscribed to the scene and transforms (tests/foxglove_client.py)
in this process, the in-process engine paced by nothing: for each message, wall time from the record that completed
its instant being handed to the view (LiveView.take) to the client reading it off the socket (both time.monotonic,
one machine). `python -m benchmarks.bench_live [--repeat N]` (also part of `make bench`); writes
benchmarks/results/live.json.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks import ROOT, save

CPF = str(Path(sys.executable).parent / "cpf")
PAPER = ROOT / "configs" / "paper.toml"


def wall(args: list[str]) -> tuple[float, float]:
    """Wall seconds of a cpf command, and the CPU seconds of it and its children (the measure on a shared machine)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    began = time.perf_counter()
    subprocess.run([CPF, *args], check=True, capture_output=True)
    elapsed = time.perf_counter() - began
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return elapsed, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def cost(repeat: int) -> dict[str, dict[str, list[tuple[float, float]]]]:
    """(wall, CPU) seconds of each (engine, live or not) run, alternating."""
    times: dict[str, dict[str, list[tuple[float, float]]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat):
            for engine in ("inprocess", "zenoh"):
                for live in (False, True):
                    args = ["run", str(PAPER), "--engine", engine, "--out", f"{tmp}/run.mcap", "--quiet"]
                    key = "live" if live else "plain"
                    times.setdefault(engine, {}).setdefault(key, []).append(wall(args + (["--live", "0"] * live)))
    return times


CLIENT = """
import sys, time
from tests.foxglove_client import FoxgloveClient
got = []
with FoxgloveClient.open(int(sys.argv[1]), {"foxglove/scene", "foxglove/transforms"}) as c:
    c.subscribe(["foxglove/scene", "foxglove/transforms"])
    print("subscribed", flush=True)
    while (r := c.receive()) is not None:
        got.append(f"{r.topic} {r.log_time} {r.at}")
print("\\n".join(got))  # at the end: a pipe nobody reads during the run would fill and stall the client
"""


def latency() -> dict[str, Any]:
    """Record-to-client latency of the scene and transforms: an in-process paper run with a client (its own process)
    subscribed. From the last vehicle state of an instant handed to the view (LiveView.take; the instant goes out
    when the next step's first state comes) to the client reading its messages (time.monotonic: one clock for all
    processes of a machine)."""
    from supervisor.config.scenario import load_scenario
    from supervisor.engine.inprocess import run_inprocess
    from supervisor.engine.progress import Progress
    from supervisor.record.live import LiveView

    scenario = load_scenario(PAPER, [], [])
    every, made = round(0.5 / scenario.scenario.step), {}
    with LiveView(0) as view, tempfile.TemporaryDirectory() as tmp:
        take = view.take

        def stamped(topic: str, t: float, message: Any) -> None:
            if topic.endswith("/state") and message.get("k", 1) % every == 0:
                made[round(t * 1e9)] = time.monotonic()  # the instant's last state so far
            take(topic, t, message)

        view.take = stamped  # type: ignore[method-assign]
        client = subprocess.Popen([sys.executable, "-c", CLIENT, str(view.port)], cwd=ROOT, stdout=subprocess.PIPE,
                                  text=True)  # fmt: skip
        assert client.stdout is not None and client.stdout.readline().strip() == "subscribed"
        time.sleep(0.2)  # the subscription reaches the server (a benchmark, not a test)
        progress = Progress(scenario.scenario.duration, sys.stderr, enabled=False)
        run_inprocess(scenario, str(PAPER), PAPER.read_text(), Path(tmp) / "run.mcap", scenario.scenario.seed,
                      progress, True, view)  # fmt: skip
        view.stop()
        lines = client.stdout.read().split("\n")
        client.wait(30)
    rows = [line.split() for line in lines if line]
    by_time = sorted(((float(at) - made[int(stamp)]) * 1e3, int(stamp) / 1e9) for _, stamp, at in rows
                     if int(stamp) in made)  # fmt: skip
    delays = [d for d, _ in by_time]
    share = {f"p{q}_ms": round(delays[int(q / 100 * (len(delays) - 1))], 2) for q in (50, 90, 99)}
    slowest = [f"{d:.1f} ms at t = {t:g} s" for d, t in by_time[-3:]]  # a stall shows as a run of instants
    return {"messages": len(delays), **share, "max_ms": round(delays[-1], 2), "slowest": slowest}


def measure(repeat: int) -> dict[str, Any]:
    """The cost of `--live 0` per engine (wall and CPU of every run, the ratios of the best) and the latency."""
    costs: dict[str, Any] = {}
    for engine, runs in cost(repeat).items():
        best = {key: (min(w for w, _ in v), min(c for _, c in v)) for key, v in runs.items()}
        costs[engine] = {
            "wall": {key: [round(w, 2) for w, _ in v] for key, v in runs.items()},
            "cpu": {key: [round(c, 2) for _, c in v] for key, v in runs.items()},
            "best_wall_ratio": round(best["live"][0] / best["plain"][0], 3),
            "best_cpu_ratio": round(best["live"][1] / best["plain"][1], 3),
        }
    return {"cost": costs if repeat else None, "latency": latency()}


def summary(row: dict[str, Any]) -> str:
    lines = [
        f"live view, nobody connected, {engine}: wall x{c['best_wall_ratio']:.3f}, CPU x{c['best_cpu_ratio']:.3f}"
        "   [target (issue 17): <= 1.10]"
        for engine, c in (row["cost"] or {}).items()
    ]
    lat = row["latency"]
    lines.append(
        f"live view latency to a client: p50 {lat['p50_ms']} ms, p99 {lat['p99_ms']} ms, max {lat['max_ms']} ms"
    )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    row = measure(args.repeat)
    print(json.dumps(row, indent=2))
    print(summary(row))
    save("live", row)


if __name__ == "__main__":
    main()

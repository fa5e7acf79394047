"""Issue 26's speed targets, each as a user waits for it: `.venv/bin/python -m benchmarks.bench_targets`.

Every case is a whole `cpf run` command (interpreter start, process start-up and the summary included), run with
both engines alternating, best of --repeat, with the spread (max - min) beside it: the machine is shared and noisy.
Cases (issue 26's numbers where it gives them, else issue 15's):
- paper: configs/paper.toml (10 Hz messages, 400 s): Zenoh lockstep <= 2x in-process (and <= 1.5x its lean bus
  floor: benchmarks.bench_critical_path);
- ring10-1hz: 10 AUVs at 1 Hz, 300 s: Zenoh <= 1.0x in-process;
- ring50-1hz: 50 AUVs on parallel lines, ring graph, one message per vehicle per second, 300 s: Zenoh with one
  process per AUV >= 20x real time;
- ring50-10hz: the same fleet messaging every step, 120 s: >= 5x (issue 15);
- ring100-1hz: 100 AUVs at 1 Hz, 120 s: >= 10x;
- ring1000-1hz: 1000 AUVs at 1 Hz, in-process only, 60 s: >= 1x;
- sweep: `cpf sweep` of the paper scenario, --jobs 2, --runs runs (issue 26: at least 200), extrapolated to 1000
  runs: <= 2 minutes (issue 26; issue 15 asked for 10).
The fleets of FORCED are also run with one process per AUV forced (`--vehicles-per-process 1`, a row of its own,
`<case>/1pp`, beside the default, which hosts them: supervisor.engine.hosting), alternating with the others. Every
Zenoh run's peak resident memory per vehicle process (bench_scaling.ProcessSampler) ends its row. Each ring's row
also gives the most its vehicles' own steps allow, from one vehicle's step timed here (benchmarks.bench_step:
vehicles.agent.step alone, less than a vehicle's whole step, so this is an upper bound): N AUVs at a step of dt need
N x (step cost) of CPU per dt simulated, so at most cores x dt / (N x cost) times real time over Zenoh and
dt / (N x cost) in-process (one thread), however cheap the bus, the channel and the recording. In-process, a fleet
of vehicles.lanes.MIN_LANES or more steps as lanes: its cost is then a vehicle's share of up to 200 of the ring's
vehicles stepped together (benchmarks.bench_lanes.measure_steps, their state messages checked against each alone).
Results go to benchmarks/results/targets.json. `--cases` picks some (comma-separated names).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks import ROOT, best_of, save
from benchmarks.bench_lanes import measure_steps
from benchmarks.bench_scaling import ProcessSampler, ring_scenario
from benchmarks.bench_step import per_step
from supervisor.config.scenario import parse_scenario
from supervisor.engine.hosting import cores, default_per_process, groups
from vehicles.lanes import MIN_LANES

CPF = [sys.executable, "-m", "supervisor.cli"]
FORCED = ("ring50-1hz", "ring50-10hz", "ring100-1hz")  # also run with one process per AUV forced
ONE_PER_AUV = ["--vehicles-per-process", "1"]


@dataclass(frozen=True)
class Case:
    name: str
    vehicles: int  # 0: the paper scenario file
    duration: float  # simulated s
    period: float | None  # s between a vehicle's messages; None: every step
    target: str  # what the issue asks, as printed
    engines: tuple[str, ...] = ("inprocess", "zenoh")


CASES = (
    Case("paper", 0, 400.0, None, "zenoh <= 2x in-process"),
    Case("ring10-1hz", 10, 300.0, 1.0, "zenoh <= 1.0x in-process"),
    Case("ring50-1hz", 50, 300.0, 1.0, "zenoh, one process per AUV, >= 20x real time"),
    Case("ring50-10hz", 50, 120.0, None, "zenoh >= 5x real time (issue 15)"),
    Case("ring100-1hz", 100, 120.0, 1.0, "zenoh >= 10x real time"),
    Case("ring1000-1hz", 1000, 60.0, 1.0, "in-process >= 1x real time", ("inprocess",)),
)


def scenario_text(case: Case) -> str:
    if case.vehicles == 0:
        return (ROOT / "configs" / "paper.toml").read_text()
    text = ring_scenario(case.vehicles, case.duration)
    period = "" if case.period is None else f"period = {case.period}\n"
    return text + f'\n[comms.transmit]\npolicy = "periodic"\n{period}'


def timed(argv: list[str], sampled: tuple[str, int, list[float]] | None = None, tree: Path = ROOT) -> float:
    """Wall time of one command, as a user waits for it; its failure stops the benchmark with its output. sampled:
    (marker, how many vehicle processes, peaks): add the peak resident memory of its largest vehicle process (MB).
    tree: the checkout it runs from, its processes importing that tree's modules (PYTHONPATH: the fork server
    starts with -P, so without it every child would import this venv's editable install, this tree)."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    start = time.perf_counter()
    with contextlib.ExitStack() as stack:
        sampler = stack.enter_context(ProcessSampler(*sampled[:2])) if sampled is not None else None
        done = subprocess.run(argv, cwd=tree, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    if sampled is not None and sampler is not None and sampler.rss:
        sampled[2].append(max(sampler.rss.values()) / 1e6)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return wall


def measure(case: Case, repeat: int, tmp: Path) -> list[dict[str, Any]]:
    """The case's row (and its /1pp row, for the fleets of FORCED), every variant run repeat times, alternating."""
    path = tmp / f"{case.name}.toml"
    path.write_text(scenario_text(case))
    runs: dict[str, list[str]] = {engine: [] for engine in case.engines}
    if case.name in FORCED:
        runs["zenoh/1pp"] = ONE_PER_AUV
    walls: dict[str, list[float]] = {variant: [] for variant in runs}
    rss: dict[str, list[float]] = {variant: [] for variant in runs}
    for _ in range(repeat):  # alternating: a burst of load on the machine hits every variant alike
        for variant, extra in runs.items():
            engine = variant.split("/")[0]
            argv = [*CPF, "run", str(path), "--engine", engine, "--out", str(tmp / "run.mcap"), *extra]
            sampled = (str(path), _vehicle_processes(case, extra), rss[variant]) if engine == "zenoh" else None
            walls[variant].append(timed(argv, sampled))
    rows = [case_row(case, case.name, walls["inprocess"], walls.get("zenoh", []), rss.get("zenoh", []))]
    if "zenoh/1pp" in runs:
        rows.append(case_row(case, f"{case.name}/1pp", walls["inprocess"], walls["zenoh/1pp"], rss["zenoh/1pp"]))
    if case.vehicles:
        bound = step_bound(case, tmp)
        for row in rows:
            row["bound"] = bound
    return rows


def step_bound(case: Case, tmp: Path, steps: int = 1000) -> dict[str, Any]:
    """The most real time the case's vehicle steps allow (see the module's docstring), from vehicle 1's step alone
    (a ring's vehicles all step alike: a line, two neighbours) timed by benchmarks.bench_step, and in-process for a
    fleet that steps as lanes, from up to 200 of them stepped together."""
    ring = Case(case.name, min(case.vehicles, 50), case.duration, case.period, case.target)  # quicker to build
    scenario = parse_scenario(scenario_text(ring), f"{case.name}.toml")
    cost, dt, n = per_step(scenario, 1, steps), scenario.scenario.step, case.vehicles
    bound = {"vehicle_step_us": cost * 1e6, "cores": cores(), "max_real_time_zenoh": cores() * dt / (n * cost),
             "max_real_time_inprocess": dt / (n * cost)}  # fmt: skip
    if n >= MIN_LANES:
        together = Case(case.name, min(n, 200), case.duration, case.period, case.target)
        path = tmp / f"{case.name}-lanes.toml"
        path.write_text(scenario_text(together))
        lanes = measure_steps(path, together.vehicles, 5)["lanes_us"] * 1e-6
        bound |= {"vehicle_step_lanes_us": lanes * 1e6, "max_real_time_inprocess": dt / (n * lanes)}
    return bound


def _vehicle_processes(case: Case, extra: list[str]) -> int:
    """How many vehicle processes the run starts (the sampler scans /proc until it has found them all)."""
    fleet = case.vehicles or 3
    per_process = 1 if extra == ONE_PER_AUV else default_per_process(fleet, cores())
    return len(groups(list(range(fleet)), per_process))


def case_row(case: Case, name: str, inprocess: list[float], zenoh: list[float], rss: list[float]) -> dict[str, Any]:
    """zenoh: [] for a case run in-process only."""
    row: dict[str, Any] = {"case": name, "duration_s": case.duration, "target": case.target}
    for engine, values in (("inprocess", inprocess), ("zenoh", zenoh)):
        if values:
            row[engine] = best_of(values)
            row[engine]["real_time_factor"] = case.duration / min(values)
    if zenoh:
        row["ratio_zenoh_to_inprocess"] = row["zenoh"]["best_s"] / row["inprocess"]["best_s"]
        row["zenoh"]["peak_rss_mb_per_vehicle_process"] = max(rss) if rss else None
    return row


def measure_sweep(runs: int, repeat: int, tmp: Path) -> dict[str, Any]:
    paper = ROOT / "configs" / "paper.toml"
    walls = []
    for n in range(repeat):
        out = tmp / f"sweep{n}"
        argv = [*CPF, "sweep", str(paper), "--param", "coordination.k=0.2", "--seeds", str(runs), "--jobs", "2"]
        walls.append(timed([*argv, "--out", str(out)]))
    return {
        "case": "sweep",
        "runs": runs,
        **best_of(walls),
        "extrapolated_1000_runs_min": min(walls) / runs * 1000 / 60,
        "target": "1000 runs <= 2 min (issue 26)",
    }


def summary(row: dict[str, Any]) -> str:
    bound = row.get("bound")
    limit = (
        f"; its vehicles' steps ({bound['vehicle_step_us']:.0f} us each alone"
        + (f", {bound['vehicle_step_lanes_us']:.0f} as lanes" if "vehicle_step_lanes_us" in bound else "")
        + f") allow at most {bound['max_real_time_zenoh']:.1f}x over Zenoh on {bound['cores']} cores, "
        f"{bound['max_real_time_inprocess']:.1f}x in-process"
        if bound
        else ""
    )
    if row["case"] == "sweep":
        return (
            f"sweep: {row['runs']} runs in {row['best_s']:.1f} s (spread {row['spread_s']:.1f} s) -> 1000 runs in "
            f"{row['extrapolated_1000_runs_min']:.1f} min   [target: {row['target']}]"
        )
    inp = row["inprocess"]
    text = f"{row['case']:12s} in-process {inp['best_s']:6.2f} s ({inp['real_time_factor']:5.1f}x, spread "
    text += f"{inp['spread_s']:.2f})"
    zen = row.get("zenoh")
    if zen is not None:
        rss = zen.get("peak_rss_mb_per_vehicle_process")
        text += (
            f"  zenoh {zen['best_s']:6.2f} s ({zen['real_time_factor']:5.1f}x, spread {zen['spread_s']:.2f})  ratio "
            f"{row['ratio_zenoh_to_inprocess']:.2f}   [target: {row['target']}]"
            + (f"  peak RSS per vehicle process {rss:.0f} MB" if rss is not None else "")
        )
    else:
        text += f"   [target: {row['target']}]"
    return text + limit


def run(names: list[str], repeat: int, sweep_runs: int) -> list[dict[str, Any]]:
    rows = []
    with tempfile.TemporaryDirectory(prefix="cpf-targets-") as tmp:
        for case in CASES:
            if case.name in names:
                for row in measure(case, repeat, Path(tmp)):
                    rows.append(row)
                    print(summary(row), flush=True)
        if "sweep" in names:
            rows.append(measure_sweep(sweep_runs, repeat, Path(tmp)))
            print(summary(rows[-1]), flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    every = [c.name for c in CASES] + ["sweep"]
    parser.add_argument("--cases", default=",".join(every), help=f"comma-separated, of: {', '.join(every)}")
    parser.add_argument("--repeat", type=int, default=2, help="runs per engine and case (best kept)")
    parser.add_argument("--runs", type=int, default=200, help="runs of the sweep case (issue 26: >= 200)")
    args = parser.parse_args()
    names = args.cases.split(",")
    unknown = sorted(set(names) - set(every))
    if unknown:
        parser.error(f"unknown case(s): {', '.join(unknown)}")
    rows = run(names, args.repeat, args.runs)
    save("targets", rows)


if __name__ == "__main__":
    main()

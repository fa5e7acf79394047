"""Every benchmark of issue 7 in one run: `.venv/bin/python -m benchmarks` (or `make bench`).

1. engines: the paper scenario with the in-process and the Zenoh lockstep engine (best of --repeat), and the ratio;
2. realtime: the paper scenario on the realtime clock at --speed 1: delivery error p50 / p99 against the
   channel's computed arrival times, and how late the vehicles began their steps;
3. scaling: N = --sizes vehicles on a ring graph, both engines: real-time factor, wall time per sync step, CPU time
   and resident memory per vehicle process;
4. bus floor: the Zenoh engine's message pattern with no work in it, for 3 and 50 vehicles: what the
   process-per-vehicle architecture costs per step before any of our code runs (and, for 50, with 25 vehicles per
   process: what grouping them would buy);
5. parse: the CPU cost of reading one bus message through its record (state, transmission, reception batch);
6. ready: how soon a vehicle process is ready (its liveliness token at the router) after its spawn;
7. live: what `cpf run --live 0` costs with nobody connected, each engine (issue 17: <= 10 %), and how late a
   client sees the scene (benchmarks.bench_live);
8. report: `cpf report` of an 8-vehicle, 450 s run as a user waits for it (issue 28: under 10 s;
   benchmarks.bench_report, which also times another checkout's alternately with --old);
9. targets: issue 26's cases as whole `cpf run` / `cpf sweep` commands, both engines side by side
   (benchmarks.bench_targets; --targets picks the cases, "none" skips them);
10. critical path: the Zenoh paper run's stepping per step against the lean bus floor measured right after it, and
   each process's CPU, threads and context switches per step (benchmarks.bench_critical_path; issue 26);
11. start-up: 10 and 50 AUVs one process each, forked from the fork server and spawned, alternating: start-up,
   stepping rate, peak memory per vehicle process (benchmarks.bench_startup; issue 26);
12. lookahead: the paper scenario on a slow modem (2 s packets), every step and event-triggered with collisions, both
   engines, with the lean bus floor of the same run (benchmarks.bench_lookahead; issue 26);
13. sweep split: a paper sweep run's CPU, whole and with its vehicle steps replayed, and the least a 1000-run sweep
   could take with a free vehicle step (benchmarks.bench_sweep_split; issue 26), then the premise of stepping many
   runs at once as arrays: the vehicle model's float functions on 1000 lanes against one state at a time, the same
   bits (benchmarks.bench_lanes);
14. collector: the ring of 1000 (10 s) and the paper in-process with the garbage collector at our pace and at
   CPython's, alternating, their messages compared (benchmarks.bench_collector; issue 26).
Each part is also a module of its own (benchmarks.bench_engines, bench_scaling, bench_realtime, bench_bus_floor,
bench_parse, bench_ready, bench_live, bench_report, bench_targets, bench_critical_path, bench_startup,
bench_lookahead, bench_sweep_split, bench_lanes, bench_collector);
benchmarks.bench_side_by_side compares this tree with another checkout; bench_record and bench_intake are
diagnostics with no target of their own. Results go to benchmarks/results/*.json; the targets are printed next to
the numbers. Speed is checked here, never in tests.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from benchmarks import (
    ROOT,
    bench_bus_floor,
    bench_collector,
    bench_critical_path,
    bench_engines,
    bench_lanes,
    bench_live,
    bench_lookahead,
    bench_parse,
    bench_ready,
    bench_realtime,
    bench_report,
    bench_scaling,
    bench_startup,
    bench_sweep_split,
    bench_targets,
    save,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=2, help="runs per engine for the paper scenario (best kept)")
    parser.add_argument("--sizes", default="3,10,30,50", help="fleet sizes for the scaling runs")
    parser.add_argument("--scaling-duration", type=float, default=20.0, help="simulated s per scaling run")
    parser.add_argument("--realtime-duration", type=float, default=60.0, help="simulated s on the realtime clock")
    every = ",".join([c.name for c in bench_targets.CASES] + ["sweep"])
    parser.add_argument("--targets", default=every, help="issue 26's target cases to run (comma-separated), or none")
    args = parser.parse_args()
    paper = ROOT / "configs" / "paper.toml"

    engines = bench_engines.measure(paper, args.repeat)
    print(bench_engines.summary(engines), flush=True)
    # Realtime before scaling: after 50 processes exit the kernel reclaims their memory for a while, and the
    # realtime tail latency measured then is the machine's, not ours.
    realtime = bench_realtime.measure(paper, args.realtime_duration, 1.0)
    print(bench_realtime.summary(realtime), flush=True)
    scaling = []
    for n in (int(s) for s in args.sizes.split(",")):
        scaling.append(bench_scaling.measure(n, args.scaling_duration))
        print(bench_scaling.summary(scaling[-1]), flush=True)

    floor = [bench_bus_floor.measure_row(n, 2000, per) for n, per in ((3, 1), (50, 1), (50, 25))]
    for row in floor:
        print(bench_bus_floor.summary(row), flush=True)

    # Issue 26: each process's CPU and context switches per step beside the lean bus floor of the same run, so that a
    # machine (or a change) that makes the engine costlier than its bus shows as such, not only as a slower wall time.
    critical = bench_critical_path.measure_paper(ROOT, args.repeat)
    print(bench_critical_path.summary(critical), flush=True)

    everything: dict[str, Any] = {"engines": engines, "scaling": scaling, "realtime": realtime, "bus_floor": floor}
    everything |= {"critical_path": critical, "startup": startup(args.scaling_duration, args.repeat)}
    everything |= {"lookahead": lookahead(args.repeat), "sweep_split": sweep_split(paper, args.repeat)}
    everything |= commands(paper, args.repeat)
    everything["collector"] = bench_collector.run(args.repeat, 10.0)
    everything["targets"] = (
        [] if args.targets == "none" else bench_targets.run(args.targets.split(","), args.repeat, 200)
    )
    print(f"written: {save('all', everything)}")


def startup(duration: float, repeat: int) -> list[dict[str, Any]]:
    """10 and 50 AUVs, one process each, forked and spawned (issue 26), each printed as measured."""
    rows = []
    for n in (10, 50):
        rows.append(bench_startup.measure(n, duration, repeat))
        print(bench_startup.summary(rows[-1]), flush=True)
    return rows


def lookahead(repeat: int) -> list[dict[str, Any]]:
    """The paper on slow and delayed links, with and without TDMA (issue 26's channel lookahead), each printed."""
    rows = []
    for name in bench_lookahead.CASES:
        rows.append(bench_lookahead.measure(name, repeat, None))
        print(bench_lookahead.summary(rows[-1]), flush=True)
    return rows


def sweep_split(paper: Path, repeat: int) -> dict[str, Any]:
    """A paper sweep run with and without its vehicle steps (issue 26's fast studies), printed."""
    split = bench_sweep_split.measure(paper, max(repeat, 2))
    print(bench_sweep_split.summary(split), flush=True)
    steps = [bench_lanes.measure_steps(paper, count, 20) for count in (6, 16, 48, 192)]
    print("paper's vehicles: " + bench_lanes.steps_summary(steps), flush=True)
    ring = paper.parent / "ring10_1hz.toml"  # line of sight on fins with its observer: a generated ring's vehicles
    sighted = [bench_lanes.measure_steps(ring, count, 20) for count in (6, 16, 48, 192)]
    print("ring10_1hz's vehicles: " + bench_lanes.steps_summary(sighted), flush=True)
    lanes = bench_lanes.measure(paper, 1000)
    print(bench_lanes.summary(lanes), flush=True)
    return {**split, "lanes": {**lanes, "steps": steps, "line_of_sight_steps": sighted}}


def commands(paper: Path, repeat: int) -> dict[str, Any]:
    """Parsing, a vehicle's readiness, the live view's cost and cpf report, each printed as measured."""
    parse = bench_parse.measure(paper)
    print(bench_parse.summary(parse), flush=True)
    ready = bench_ready.measure(5)
    print(bench_ready.summary(ready), flush=True)
    live = bench_live.measure(repeat)
    print(bench_live.summary(live), flush=True)
    report = bench_report.measure(repeat, None)
    print(bench_report.summary(report), flush=True)
    return {"parse": parse, "ready": ready, "live": live, "report": report}


if __name__ == "__main__":
    main()

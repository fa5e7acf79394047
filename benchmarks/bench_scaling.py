"""How the engines scale with fleet size: `.venv/bin/python -m benchmarks.bench_scaling [--sizes 3,10,30,50]`.

N vehicles on parallel straight lines 10 m apart (an in-line formation) over a ring graph, for --duration
simulated seconds with each engine. Prints and writes to benchmarks/results/scaling.json: real-time factor, wall
time per sync step (both while stepping: the Zenoh engine's process start-up is reported apart), and for the
Zenoh engine the CPU time (start-up included) and peak resident memory per vehicle process, sampled from /proc.
Target (issue 7): 50 vehicles at >= 5x real time on 2 cores.
"""

from __future__ import annotations

import argparse
import io
import os
import tempfile
import threading
from pathlib import Path
from typing import Any

from benchmarks import save
from supervisor.config.scenario import parse_scenario
from supervisor.engine.cosim import BusOptions, run_zenoh
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress

TICKS = os.sysconf("SC_CLK_TCK")
PAGE = os.sysconf("SC_PAGE_SIZE")


def ring_scenario(n: int, duration: float) -> str:
    """N AUVs on parallel lines, a ring graph, every one starting a little off its line."""
    edges = ", ".join(f"[{i}, {i % n + 1}]" for i in range(1, n + 1))
    vehicles = "".join(
        f"""
[[vehicles]]
id = {i}
position = [{-3.0 + (i % 4)}, {10.0 * i + 2.0}, -10.0]
path = {{ type = "line", start = [0.0, {10.0 * i}, -10.0], velocity = [1.0, 0.0, 0.0] }}
"""
        for i in range(1, n + 1)
    )
    head = f'[scenario]\nname = "ring{n}"\nduration = {duration}\nstep = 0.1\n\n[graph]\nedges = [{edges}]\n'
    return head + vehicles


class ProcessSampler:
    """Samples CPU time and resident memory of the processes whose command line mentions a marker."""

    def __init__(self, marker: str, expected: int) -> None:
        self.marker, self.expected = marker, expected
        self.cpu: dict[int, float] = {}
        self.rss: dict[int, int] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    def __enter__(self) -> ProcessSampler:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join()

    def _loop(self) -> None:
        found: list[int] = []
        while not self._stop.wait(0.2):
            if len(found) < self.expected:  # scanning /proc costs: only until every vehicle process is there
                found = self._vehicles()
            for pid in found:
                self._sample(pid)

    def _vehicles(self) -> list[int]:
        pids = []
        for entry in Path("/proc").iterdir():
            if entry.name.isdigit():
                try:
                    cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                except OSError:
                    continue
                if self.marker in cmd and " vehicle " in cmd:
                    pids.append(int(entry.name))
        return pids

    def _sample(self, pid: int) -> None:
        try:
            stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            pages = int(Path(f"/proc/{pid}/statm").read_text().split()[1])
        except OSError:
            return
        self.cpu[pid] = (int(stat[11]) + int(stat[12])) / TICKS  # utime + stime
        self.rss[pid] = max(self.rss.get(pid, 0), pages * PAGE)


def measure(n: int, duration: float) -> dict[str, Any]:
    text = ring_scenario(n, duration)
    steps = round(duration / 0.1)
    row: dict[str, Any] = {"vehicles": n, "duration_s": duration}
    with tempfile.TemporaryDirectory(prefix=f"cpf-scale-{n}-") as tmp:
        path = Path(tmp) / f"ring{n}.toml"
        path.write_text(text)
        scenario = parse_scenario(text, str(path))
        quiet = Progress(duration, io.StringIO(), False)
        result = run_inprocess(scenario, str(path), text, Path(tmp) / "i.mcap", 0, quiet)
        row["inprocess"] = _rates(result.stepping_time, duration, steps)
        with ProcessSampler(str(path), n) as sampler:
            quiet = Progress(duration, io.StringIO(), False)
            result = run_zenoh(scenario, path, text, Path(tmp) / "z.mcap", 0, "lockstep", 1.0, BusOptions(), quiet)
        count = max(1, len(sampler.rss))
        row["zenoh"] = {
            **_rates(result.stepping_time, duration, steps),
            "startup_s": result.wall_time - result.stepping_time,
            "cpu_s_per_vehicle_process": sum(sampler.cpu.values()) / count,
            "peak_rss_mb_per_vehicle_process": sum(sampler.rss.values()) / count / 2**20,
        }
    return row


def _rates(stepping: float, duration: float, steps: int) -> dict[str, float]:
    """Real-time factor and wall time per sync step while stepping (process start-up is reported apart)."""
    return {"stepping_s": stepping, "real_time_factor": duration / stepping, "ms_per_step": 1e3 * stepping / steps}


def summary(row: dict[str, Any]) -> str:
    inp, zen = row["inprocess"], row["zenoh"]
    return (
        f"N={row['vehicles']:3d}  inprocess {inp['real_time_factor']:6.1f}x ({inp['ms_per_step']:6.1f} ms/step)   "
        f"zenoh {zen['real_time_factor']:6.1f}x ({zen['ms_per_step']:6.1f} ms/step; start-up {zen['startup_s']:.1f} s; "
        f"{zen['cpu_s_per_vehicle_process']:.2f} s CPU and {zen['peak_rss_mb_per_vehicle_process']:.0f} MB "
        f"per vehicle process)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default="3,10,30,50", help="fleet sizes, comma-separated")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds per run")
    args = parser.parse_args()
    rows = []
    for n in (int(s) for s in args.sizes.split(",")):
        rows.append(measure(n, args.duration))
        print(summary(rows[-1]), flush=True)
    save("scaling", rows)


if __name__ == "__main__":
    main()

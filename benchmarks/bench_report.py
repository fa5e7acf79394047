"""`cpf report` on an 8-vehicle, 450 s run as a user waits for it (issue 28: under 10 s):
`.venv/bin/python -m benchmarks.bench_report [--repeat N] [--old DIR]`.

The run: tests/data/fig_circles8.toml (eight AUVs on concentric circles, a ring with two chords, 10 % loss, a link
down for 40 s and vehicle 5 killed and restarted) for 450 s on the in-process engine; its log, 127 000 messages and
16 figures. The report is timed as a whole command (interpreter start to exit), best of --repeat with the spread
(max - min): the machine is shared and noisy. With --old DIR (a checkout with its own .venv), that tree's `cpf report`
of the same log runs alternately with this one's: the ratio is what to quote. Results: benchmarks/results/report.json.
"""

from __future__ import annotations

import argparse
import re
import resource
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks import ROOT, save

TARGET = 10.0  # s, issue 28
SCENARIO = ROOT / "tests" / "data" / "fig_circles8.toml"
DURATION = 450.0


def make_log(where: Path) -> Path:
    scenario = where / "ring8.toml"
    text = SCENARIO.read_text()
    scenario.write_text(re.sub(r"(?m)^duration = .*$", f"duration = {DURATION}", text, count=1))
    log = where / "ring8.mcap"
    cpf = str(ROOT / ".venv" / "bin" / "cpf")
    subprocess.run([cpf, "run", str(scenario), "--engine", "inprocess", "--out", str(log), "--quiet"], check=True)
    return log


def report_once(tree: Path, log: Path, out: Path) -> dict[str, float]:
    """Wall s and CPU s (user + system of the command and the drawing workers it waited for)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    cpf = str(tree / ".venv" / "bin" / "cpf")
    subprocess.run([cpf, "report", str(log), "--out", str(out)], cwd=tree, capture_output=True, check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {"wall_s": wall, "cpu_s": after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime}


def measure(repeat: int, old: Path | None) -> dict[str, Any]:
    trees = {"this": ROOT, **({"old": old} if old is not None else {})}
    with tempfile.TemporaryDirectory() as tmp:
        log = make_log(Path(tmp))
        runs: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
        for i in range(repeat):
            for name, tree in trees.items():
                runs[name].append(report_once(tree, log, Path(tmp) / f"{name}{i}"))
    return {name: _stats(rows) for name, rows in runs.items()}


def _stats(rows: list[dict[str, float]]) -> dict[str, float]:
    walls, cpus = [r["wall_s"] for r in rows], [r["cpu_s"] for r in rows]
    return {
        "best_wall_s": min(walls),
        "spread_wall_s": max(walls) - min(walls),
        "best_cpu_s": min(cpus),
        "runs": len(rows),
    }


def summary(results: dict[str, Any]) -> str:
    lines = []
    for name, r in results.items():
        lines.append(
            f"cpf report, 8 vehicles x {DURATION:g} s ({name}): best {r['best_wall_s']:.2f} s wall (spread "
            f"{r['spread_wall_s']:.2f} s over {r['runs']}), {r['best_cpu_s']:.2f} s CPU; target < {TARGET:g} s"
        )
    if "old" in results:
        lines.append(
            f"ratio this / old (best wall): {results['this']['best_wall_s'] / results['old']['best_wall_s']:.2f}"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--old", type=Path, help="another checkout (with its .venv), timed alternately")
    args = parser.parse_args()
    results = measure(args.repeat, args.old)
    print(summary(results))
    save("report", results)


if __name__ == "__main__":
    main()

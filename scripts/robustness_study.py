"""The robustness study (README, "Robustness study"): which of the disturbances of configs/studies/robustness.toml
dominates, and how the errors grow with the navigation fix period and the current's speed.

`make study` (or `python scripts/robustness_study.py [--seeds N] [--jobs N] [--out DIR]`) runs the study scenario
with each effect alone, with none and with all, every one over the same seeds (the seed draws the plant, the sensor
noise and the losses), in-process and recorded, then a sweep over the fix period and one over the current's speed
with every other effect on. It writes DIR/results.csv (one row per run), DIR/table.md (median and range across
seeds) and the figures DIR/study_effects.png and DIR/study_sweeps.png; progress goes to stderr.

Measures, from each run's log (t: simulation time; the transient is the scenario's report.transient = 50 s):
- path error: |p - p_d(gamma)| of the TRUE position; max after the transient, and steady = max over the last 50 s;
- coordination error: max_ij |gamma_i - gamma_j|; settled = max over [100, 150) and [300, 400] s (50 s after the
  start and after the speed_cap fault ends: the disturbances' own level, not the paper's fault), steady = max over
  the last 50 s;
- navigation error |p_hat - p|: mean and max after the transient (0 without navigation);
- loss: share of the packets sent that were lost.
"""

from __future__ import annotations

import argparse
import copy
import csv
import io
import sys
import tempfile
import tomllib
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
STUDY = ROOT / "configs" / "studies" / "robustness.toml"
EFFECTS = ("none", "current", "navigation", "mismatch", "loss", "all")
FIX_PERIODS = (2.0, 5.0, 10.0, 20.0, 40.0)
CURRENTS = (0.0, 0.05, 0.1, 0.2, 0.3)
SETTLED = ((100.0, 150.0), (300.0, 400.0))  # s: after the initial transient, and 50 s after the fault ends
STEADY = 50.0  # s at the end of the run
Run = tuple[str, str, float, int]  # (group, effect, swept value, seed)


def variant(base: dict[str, Any], effect: str) -> dict[str, Any]:
    """The study scenario with only `effect` on ("none": none of them, "all": the file as it is)."""
    data = copy.deepcopy(base)
    keep = {"all": set(EFFECTS), "none": set()}.get(effect, {effect})
    if "current" not in keep:
        data["environment"]["current"] = [0.0, 0.0, 0.0]
    if "navigation" not in keep:
        del data["navigation"]
    if "mismatch" not in keep:
        data["vehicle"]["uncertainty"] = 0.0
    if "loss" not in keep:  # the same modem and TDMA frame, without the range-dependent loss
        del data["comms"]["range"]
    return data


def scenario_data(base: dict[str, Any], run: Run) -> dict[str, Any]:
    """The scenario of one run: an effect variant, or everything on with the fix period or current swept."""
    group, effect, value, seed = run
    data = variant(base, effect)
    data["scenario"]["seed"] = seed
    if group == "fix_period":
        data["navigation"]["fix_period"] = value
    elif group == "current":
        data["environment"]["current"] = [value, 0.0, 0.0]
    return data


def measure(data: dict[str, Any], run: Run) -> dict[str, Any]:
    """Run one scenario in-process (recorded to a temporary log) and return its row of measures."""
    from supervisor.analysis.rundata import load_run
    from supervisor.config.scenario import validate_data
    from supervisor.engine.inprocess import run_inprocess
    from supervisor.engine.progress import Progress

    scenario = validate_data(data, str(STUDY))
    quiet = Progress(scenario.scenario.duration, io.StringIO(), enabled=False)
    with tempfile.TemporaryDirectory(prefix="cpf-study-") as tmp:
        log = Path(tmp) / "run.mcap"
        result = run_inprocess(scenario, str(STUDY), STUDY.read_text(), log, scenario.scenario.seed, quiet)
        recorded = load_run(log)
    series = result.series
    counts = result.link_counts
    return {
        "group": run[0], "effect": run[1], "value": run[2], "seed": run[3],
        **_errors(series.t, series.path_error, series.gamma, scenario.report.transient),
        **_navigation(recorded, scenario.report.transient),
        "loss": counts["dropped"] / max(counts["sent"], 1),
    }  # fmt: skip


def _errors(t: np.ndarray, path: np.ndarray, gamma: np.ndarray, transient: float) -> dict[str, float]:
    from supervisor.analysis.summary import coordination_error

    coordination = coordination_error(gamma)
    after, last = t >= transient, t >= t[-1] - STEADY
    settled = np.zeros_like(t, dtype=bool)
    for start, end in SETTLED:
        settled |= (t >= start) & (t < end) if end < t[-1] else t >= start
    return {
        "path_max": float(np.nanmax(path[after])),
        "path_steady": float(np.nanmax(path[last])),
        "coord_settled": float(np.nanmax(coordination[settled])),
        "coord_steady": float(np.nanmax(coordination[last])),
    }


def _navigation(recorded: Any, transient: float) -> dict[str, float]:
    """Mean and max |p_hat - p| after the transient over the fleet (0: no navigation, the controller sees truth)."""
    errors = [s.nav_error[s.t >= transient] for s in recorded.vehicles.values() if s.nav_error is not None]
    if not errors:
        return {"nav_mean": 0.0, "nav_max": 0.0}
    joined = np.concatenate(errors)
    return {"nav_mean": float(joined.mean()), "nav_max": float(joined.max())}


def _one(base: dict[str, Any], run: Run) -> dict[str, Any]:
    return measure(scenario_data(base, run), run)


def plan(seeds: int) -> list[Run]:
    runs: list[Run] = [("effects", e, 0.0, s) for e in EFFECTS for s in range(seeds)]
    runs += [("fix_period", "all", v, s) for v in FIX_PERIODS for s in range(seeds)]
    runs += [("current", "all", v, s) for v in CURRENTS for s in range(seeds)]
    return runs


def run_all(runs: list[Run], jobs: int, report: Callable[[int, int, Run], None]) -> list[dict[str, Any]]:
    """Every run, jobs at a time; rows in the plan's order."""
    base = tomllib.loads(STUDY.read_text())
    rows: dict[Run, dict[str, Any]] = {}
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = {pool.submit(_one, base, run): run for run in runs}
        for future in as_completed(futures):
            rows[futures[future]] = future.result()
            report(len(rows), len(runs), futures[future])
    return [rows[run] for run in runs]


COLUMNS = (
    ("path_max", "path error max [m]"),
    ("path_steady", "path error steady [m]"),
    ("coord_settled", "coord. error settled"),
    ("coord_steady", "coord. error steady"),
    ("nav_mean", "nav. error mean [m]"),
    ("loss", "loss"),
)


def table(rows: list[dict[str, Any]], group: str, key: str) -> str:
    """A Markdown table of one group: per value of `key`, the median [min-max] across seeds of every measure."""
    lines = [f"| {key} | " + " | ".join(name for _, name in COLUMNS) + " |", "|---" * (len(COLUMNS) + 1) + "|"]
    chosen = [r for r in rows if r["group"] == group]
    for value in dict.fromkeys(r[key] for r in chosen):
        these = [r for r in chosen if r[key] == value]
        cells = [_cell(np.array([r[c] for r in these])) for c, _ in COLUMNS]
        lines.append(f"| {value} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(values: np.ndarray) -> str:
    return f"{np.median(values):.3g} [{values.min():.3g}-{values.max():.3g}]"


def plot_effects(rows: list[dict[str, Any]], out: Path) -> Path:
    """One panel per measure: each effect's runs (dots, one per seed) and their median (bar)."""
    from supervisor.analysis.figures import new_figure, save

    fig = new_figure(15.0, 4.5)
    axes = fig.subplots(1, 5)
    chosen = [r for r in rows if r["group"] == "effects"]
    for ax, (column, name) in zip(axes, COLUMNS[:5], strict=True):
        for k, effect in enumerate(EFFECTS):
            values = np.array([r[column] for r in chosen if r["effect"] == effect])
            ax.bar(k, np.median(values), color="0.85", edgecolor="0.4")
            ax.plot(np.full(values.size, k), values, "o", ms=3, color="C0")
        ax.set_xticks(range(len(EFFECTS)), EFFECTS, rotation=45, ha="right")
        ax.set_title(name, fontsize="small")
        ax.grid(axis="y", alpha=0.3)
        if column.startswith("coord"):  # from 1e-5 (nothing but the fault) to 0.1 (the current)
            ax.set_yscale("log")
    fig.suptitle("Robustness study: each effect alone, none and all (bars: median; dots: seeds)")
    return save(fig, out)


def plot_sweeps(rows: list[dict[str, Any]], out: Path) -> Path:
    """Errors against the fix period and against the current's speed (every other effect on), with the trends
    theory gives: navigation error ~ sqrt(fix period), path offset ~ current speed."""
    from supervisor.analysis.figures import new_figure, save

    fig = new_figure(14.0, 5.0)
    fix_ax, current_ax = fig.subplots(1, 2)
    for ax, group, label in ((fix_ax, "fix_period", "navigation.fix_period [s]"),
                             (current_ax, "current", "environment.current x [m/s]")):  # fmt: skip
        chosen = [r for r in rows if r["group"] == group]
        values = sorted({r["value"] for r in chosen})
        for column, name, colour in (("nav_mean", "nav. error mean [m]", "C0"),
                                     ("path_steady", "path error steady [m]", "C1"),
                                     ("coord_steady", "coord. error steady [gamma]", "C2")):  # fmt: skip
            data = [np.array([r[column] for r in chosen if r["value"] == v]) for v in values]
            median = [float(np.median(d)) for d in data]
            ax.plot(values, median, "o-", color=colour, label=name)
            ax.fill_between(values, [d.min() for d in data], [d.max() for d in data], color=colour, alpha=0.15)
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    _theory(fix_ax)
    fix_ax.set_title("Against the fix period (all effects on)")
    current_ax.set_title("Against the current's speed (all effects on)")
    fig.suptitle("Robustness study sweeps: median across seeds, band min-max")
    for ax in (fix_ax, current_ax):
        ax.legend(fontsize="x-small")
    return save(fig, out)


def nav_theory(period: float, transient: float = 50.0, duration: float = 400.0, noise: float = 1.0) -> float:
    """Mean |p_hat - p| over [transient, duration] if the filter did nothing but average the fixes: the dead
    reckoning between fixes adds ~1 cm (DVL and heading noise over 40 s), so after n fixes each horizontal axis is
    off by noise / sqrt(1 + n) (the initial estimate counting as one fix of the same noise), and the mean norm of a
    2-D Gaussian is sqrt(pi / 2) sigma. Goes as sqrt(period) while n >> 1."""
    t = np.arange(transient, duration, 0.1)
    return float(np.mean(np.sqrt(np.pi / 2.0) * noise / np.sqrt(1.0 + np.floor(t / period))))


def _theory(ax: Any) -> None:
    periods = np.linspace(min(FIX_PERIODS), max(FIX_PERIODS), 60)
    ax.plot(periods, [nav_theory(p) for p in periods], "k:", label="nav. error, averaging the fixes (theory)")


def write_csv(rows: list[dict[str, Any]], path: Path) -> None:
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=5, help="seeds per case (default: 5)")
    parser.add_argument("--jobs", type=int, default=2, help="runs at a time (default: 2)")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "study", help="output directory")
    parser.add_argument("--replot", action="store_true", help="redraw the table and figures from DIR/results.csv")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = read_csv(args.out / "results.csv") if args.replot else run_all(plan(args.seeds), args.jobs, _progress)
    write_csv(rows, args.out / "results.csv")
    text = "\n\n".join(
        [table(rows, "effects", "effect"), table(rows, "fix_period", "value"), table(rows, "current", "value")]
    )
    (args.out / "table.md").write_text(text + "\n")
    print(text)
    for path in (plot_effects(rows, args.out / "study_effects.png"), plot_sweeps(rows, args.out / "study_sweeps.png")):
        print(f"robustness_study: wrote {path}", file=sys.stderr)
    return 0


def _progress(done: int, total: int, run: Run) -> None:
    print(f"robustness_study: {done}/{total} runs ({run[0]} {run[1]} {run[2]:g}, seed {run[3]})", file=sys.stderr)


def read_csv(path: Path) -> list[dict[str, Any]]:
    """The rows results.csv holds, numbers as numbers."""
    with path.open(newline="") as stream:
        rows = list(csv.DictReader(stream))
    return [{k: v if k in ("group", "effect") else float(v) for k, v in row.items()} for row in rows]


if __name__ == "__main__":
    raise SystemExit(main())

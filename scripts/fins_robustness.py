"""A REMUS 100 on its fins under model mismatch (README, "Robust vehicles"; issue 24): inline5 with the remus100
preset's fins and the default controller (line_of_sight with its disturbance observer), each coefficient of each
plant drawn within +-uncertainty of the model's, at the paths' 1 m/s and at 1.5 m/s, seeds 0-9.

`python scripts/fins_robustness.py [--speeds 1.0,1.5] [--seeds N] [--jobs N] [--out DIR]` (`make study` runs it):
DIR/fins.md (the table) and DIR/fins.csv (one row per vehicle and run). Each run is in process (`cpf.run`); ~8 min
on 2 cores for the 60 runs.

Per run: each vehicle's largest path error after the transient (120 s) against the tube (1.2 m), the coordination
error max_ij |gamma_i - gamma_j| over the last 50 s, and the vehicles `cpf validate` says their fins cannot hold on
their paths at that speed (supervisor.config.authority_checks: their trim needs more pitch moment than the fins
give; vehicles.trim). The table separates the vehicles that leave their tube with a trim their fins hold (the
controller's failures) from those whose fins cannot hold it (no controller's).
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
INLINE5 = ROOT / "configs" / "inline5.toml"
UNCERTAINTIES = (0.2, 0.4, 0.6)
TUBE = 1.2  # m: line_of_sight's tube on inline5 (`cpf validate` says it)
WINDOW = 50.0  # s: the coordination error's window at the end
SETTLED = 0.05


def measure(speed: float, spread: float, seed: int) -> tuple[dict[int, float], float, list[int]]:
    """(vehicle -> path error after the transient, coordination error over the last 50 s, the vehicles whose fins
    cannot hold their trim) of one run."""
    import logging

    import cpf
    from supervisor.config.authority_checks import unheld

    logging.disable(logging.WARNING)  # cpf.run says what unheld says, once per run: the table counts it
    from supervisor.config.scenario import parse_scenario

    sets = [f"coordination.v_r={speed}", f"vehicle.uncertainty={spread}", f"scenario.seed={seed}"]
    scenario = parse_scenario(INLINE5.read_text(), str(INLINE5), sets)
    unable = sorted(unheld(scenario))
    states = cpf.run(INLINE5, set=sets, progress=False).states
    after = states[states.t >= scenario.report.transient].groupby("vehicle").path_error.max()
    gammas = states.pivot(index="t", columns="vehicle", values="gamma")
    spread_of_gammas = gammas.max(axis=1) - gammas.min(axis=1)
    last = float(spread_of_gammas[spread_of_gammas.index >= spread_of_gammas.index.max() - WINDOW].max())
    return {int(v): float(e) for v, e in after.items()}, last, unable


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speeds", default="1.0,1.5")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "study")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    cases = [(float(v), u, s) for v in args.speeds.split(",") for u in UNCERTAINTIES for s in range(args.seeds)]
    with ProcessPoolExecutor(args.jobs) as pool:
        results = dict(zip(cases, pool.map(measure, *zip(*cases, strict=True)), strict=True))
    lines = ["speed,uncertainty,seed,vehicle,path_error_after_transient,fins_cannot_hold,coordination_error_last_50s"]
    for (v, u, s), (errors, coord, unable) in results.items():
        lines += [f"{v},{u},{s},{i},{e:.6g},{int(i in unable)},{coord:.6g}" for i, e in errors.items()]
    (args.out / "fins.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    rows = table(results)
    (args.out / "fins.md").write_text("\n".join(rows) + "\n", encoding="utf-8")
    print("\n".join(rows))
    return 0


def table(results: dict[tuple[float, float, int], tuple[dict[int, float], float, list[int]]]) -> list[str]:
    """One row per speed and uncertainty."""
    rows = ["| speed [m/s] | vehicle.uncertainty | seeds all in the tube | settled (< 0.05) | vehicles out of the tube "
            "| of them, fins cannot hold their trim | fins cannot hold, yet in the tube | worst path error of the "
            "vehicles whose fins can [m] |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for v, u in dict.fromkeys((v, u) for v, u, _ in results):
        runs = [value for (vv, uu, _), value in results.items() if (vv, uu) == (v, u)]
        inside = sum(all(e <= TUBE for e in errors.values()) for errors, _, _ in runs)
        settled = sum(coord < SETTLED for _, coord, _ in runs)
        out = [(i in unable) for errors, _, unable in runs for i, e in errors.items() if e > TUBE]
        held = [i for errors, _, unable in runs for i, e in errors.items() if i in unable and e <= TUBE]
        able = [e for errors, _, unable in runs for i, e in errors.items() if i not in unable]
        rows.append(
            f"| {v:g} | {u:g} | {inside}/{len(runs)} | {settled}/{len(runs)} | {len(out)} | {sum(out)} | {len(held)} "
            f"| {max(able, default=0.0):.3g} |"
        )
    return rows


if __name__ == "__main__":
    raise SystemExit(main())

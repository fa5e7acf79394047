"""Coordination on real links (README, "Coordination on slow links"; issue 23): the paper scenario, its speed_cap fault
included, with a message every 10, 20 or 30 s, with and without 8 s of airtime, under the defaults and under the
former ones (first_order predictor, k as given, no bound on the correction); and the period x loss map with the
stability analysis' predicted decay rate beside the simulated error.

`python scripts/real_links_study.py [--jobs N] [--out DIR]` (`make study` runs it): DIR/real_links.md (the table),
DIR/period_loss.csv and DIR/period_loss_map.png. ~2 min on 2 cores. Each run is in process and not recorded
(supervisor.tools.stability_check.simulate).

Measures: coordination error c(t) = max_ij |gamma_i - gamma_j|, its largest value over the last 50 s; path error:
the largest |p_i - p_d_i(gamma_i)| of any vehicle after the 50 s transient (the tube is 1.2 m).
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from supervisor.config.stability.schedule import CANDIDATES  # noqa: E402  (after the path)

PAPER = ROOT / "configs" / "paper.toml"
FORMER = ["coordination.predictor=first_order", "coordination.schedule=none", "saturation.correction=none"]
AIRTIME_8S = ["comms.bitrate=15"]  # a 15-byte message at 15 bit/s: 8 s on air
NO_FAULT = ["faults=[]"]
# The gains the schedule chooses among (supervisor.config.stability.schedule), from the paper's k = 0.2.
GAINS = tuple(0.2 * 2.0 ** (-m / 4) for m in range(CANDIDATES))
PERIODS = (1.0, 5.0, 10.0, 20.0, 30.0)
LOSSES = (0.0, 0.1, 0.3, 0.5)


def measure(overrides: list[str]) -> tuple[float, float]:
    """(coordination error over the last 50 s, path error after the transient) of the paper scenario so changed."""
    from supervisor.config.scenario import parse_scenario
    from supervisor.tools.stability_check import simulate

    outcome = simulate(parse_scenario(PAPER.read_text(), str(PAPER), overrides))
    return outcome.last, outcome.path_error


def predicted_rate(overrides: list[str]) -> float:
    from supervisor.config.scenario import parse_scenario
    from supervisor.config.stability import rate
    from supervisor.config.stability.scenario import setting_of

    return rate(setting_of(parse_scenario(PAPER.read_text(), str(PAPER), overrides)))


def acceptance_rows(pool: ProcessPoolExecutor) -> list[str]:
    """The issue-23 acceptance rows: the defaults, the same without the fault, law (5) at the best of the schedule's
    candidate gains (k fixed, no schedule), and the former defaults."""
    cases = [(f"{p:g} s", [f"comms.transmit.period={p}"]) for p in (10.0, 20.0, 30.0)]
    cases = [*cases, *((f"{name}, 8 s on air", [*o, *AIRTIME_8S]) for name, o in [("every step", []), *cases])]
    variants = {"defaults": [], "no fault": NO_FAULT, "former": FORMER}
    runs = {(name, v): pool.submit(measure, [*o, *extra]) for name, o in cases for v, extra in variants.items()}
    gains = {(name, k): pool.submit(measure, [*o, "coordination.schedule=none", f"coordination.k={k:.6g}"])
             for name, o in cases for k in GAINS}  # fmt: skip
    rows = ["| messages | coord. error, last 50 s | path error [m] | without the fault: coord. | path [m] "
            "| law (5), best fixed k: coord. (k) | former defaults: coord. | path [m] |",
            "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for name, _ in cases:
        (c, p), (nc, np_), (fc, fp) = (runs[(name, v)].result() for v in variants)
        best_c, best_k = min((gains[(name, k)].result()[0], k) for k in GAINS)
        rows.append(f"| {name} | {c:.3g} | {p:.3g} | {nc:.3g} | {np_:.3g} | {best_c:.3g} ({best_k:.3g}) | {fc:.3g} "
                    f"| {fp:.3g} |")  # fmt: skip
    return rows


def period_loss(pool: ProcessPoolExecutor) -> tuple[np.ndarray, np.ndarray]:
    grid = [[f"comms.transmit.period={p}", f"comms.loss={q}"] for q in LOSSES for p in PERIODS]
    simulated = [pool.submit(measure, o) for o in grid]
    rates = [predicted_rate(o) for o in grid]
    shape = (len(LOSSES), len(PERIODS))
    return np.array([f.result()[0] for f in simulated]).reshape(shape), np.array(rates).reshape(shape)


def draw(error: np.ndarray, rates: np.ndarray, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import patheffects

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    panels = [(np.log10(np.maximum(error, 1e-6)), "simulated: log10 coordination error, last 50 s", "viridis", error),
              (rates, "predicted decay rate [1/s] (cpf stability)", "magma", rates)]  # fmt: skip
    for ax, (values, title, cmap, shown) in zip(axes, panels, strict=True):
        image = ax.imshow(values, origin="lower", cmap=cmap, aspect="auto")
        ax.set_xticks(range(len(PERIODS)), [f"{p:g}" for p in PERIODS])
        ax.set_yticks(range(len(LOSSES)), [f"{q:g}" for q in LOSSES])
        ax.set_xlabel("transmit period [s]")
        ax.set_ylabel("independent loss")
        ax.set_title(title, fontsize=10)
        for (i, j), v in np.ndenumerate(shown):
            label = ax.text(j, i, f"{v:.2g}", ha="center", va="center", color="w", fontsize=8)
            label.set_path_effects([patheffects.withStroke(linewidth=2, foreground="k")])  # legible on any colour
        fig.colorbar(image, ax=ax)
    fig.suptitle("Paper scenario (speed_cap fault included), default coordination: period x loss")
    fig.savefig(out, dpi=110)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "study")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = acceptance_rows(pool)
        print("\n".join(rows), file=sys.stderr)
        error, rates = period_loss(pool)
    (args.out / "real_links.md").write_text("\n".join(rows) + "\n", encoding="utf-8")
    lines = ["loss,period,coordination_error_last_50s,predicted_rate"]
    lines += [
        f"{q},{p},{error[i, j]:.6g},{rates[i, j]:.6g}" for i, q in enumerate(LOSSES) for j, p in enumerate(PERIODS)
    ]
    (args.out / "period_loss.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    draw(error, rates, args.out / "period_loss_map.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

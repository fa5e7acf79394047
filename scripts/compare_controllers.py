"""Path-following controllers side by side on scenarios (README, "A controller with bounded demands"; issue 24).

`python scripts/compare_controllers.py [--controllers backstepping,line_of_sight] [--set KEY=VALUE ...] [--jobs N]
SCENARIO.toml ...` prints a Markdown table, a row per scenario and controller: the largest path error
|p_i - p_d_i(gamma_i)| after the scenario's transient (`report.transient`) and over the last 50 s [m], whether the
vehicles stayed in the tube, the coordination error at the end (the run summary's steady-state error) and when it
first fell below the report's tolerance [s]. Each run is in process (`cpf.run`), one per job.
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
LAST = 50.0  # s: the window the settled path error is taken over


def measure(scenario: str, controller: str, sets: list[str]) -> str:
    import cpf

    run = cpf.run(scenario, set=[f"path_following.controller={controller}", *sets], progress=False)
    pf, co = run.summary["path_following"], run.summary["coordination"]
    states = run.states
    late = states[states.t >= states.t.max() - LAST].path_error.max()
    settled = "-" if co["convergence_time"] is None else f"{co['convergence_time']:.0f}"
    inside = "yes" if pf["inside_tube"] else "no"
    return (
        f"| {Path(scenario).stem} | {controller} | {pf['max_error_after_transient']:.2f} | {late:.2f} | {inside} "
        f"| {co['steady_state_error']:.2g} | {settled} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="+")
    parser.add_argument("--controllers", default="backstepping,line_of_sight")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="as cpf run --set")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    pairs = [(s, c) for s in args.scenarios for c in args.controllers.split(",")]
    print("| scenario | controller | path error after the transient [m] | last 50 s [m] | in the tube "
          "| coordination error at the end | below tolerance from [s] |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    with ProcessPoolExecutor(args.jobs) as pool:
        for row in pool.map(measure, *zip(*pairs, strict=True), [args.set] * len(pairs)):
            print(row, flush=True)


if __name__ == "__main__":
    main()

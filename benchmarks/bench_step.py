"""CPU cost of one vehicle's closed-loop step: `.venv/bin/python -m benchmarks.bench_step [--scenario S] [--vehicle I]`.

Times vehicles.agent.step (RK4 of dynamics + path following + coordination) for one vehicle of a scenario, with
estimates of its neighbours held so that coordination does its work, and prints the best of 5 rounds in us per step.
The in-process engine spends about this per vehicle per step; the rest of its time is the channel and the recording.
"""

from __future__ import annotations

import argparse
import timeit
from dataclasses import replace
from pathlib import Path

from supervisor.config.fleet import initial_state, vehicle_config
from supervisor.config.scenario import load_scenario
from vehicles.agent import step
from vehicles.estimates import NeighbourEstimate

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--vehicle", type=int, default=1)
    parser.add_argument("--steps", type=int, default=4000)
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    cfg = vehicle_config(scenario, args.vehicle)
    dt = scenario.scenario.step
    neighbours = scenario.neighbours(args.vehicle)
    state = initial_state(scenario, cfg)
    heard = {j: NeighbourEstimate(state.gamma, 0.5 * cfg.coordination.v_r, 0.0) for j in neighbours}
    state = replace(state, estimates=heard)
    for _ in range(50):  # away from the start, where some terms are exactly zero
        state = step(cfg, state, dt, neighbours)[0]
    rounds = timeit.repeat(lambda: step(cfg, state, dt, neighbours), number=args.steps, repeat=5)
    print(f"vehicle {args.vehicle} of {args.scenario.name}: {min(rounds) / args.steps * 1e6:.1f} us per step")


if __name__ == "__main__":
    main()

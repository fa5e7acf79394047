"""Law (5)'s coupling gain k fitted to the links: lowered, when messages are rare or late, to the gain at which the
linearised sampled loop of `cpf stability` decays fastest.

Why: a coupling gain right for continuous communication over-corrects from old information when a neighbour is
heard every P s. Each vehicle's gamma moves continuously towards neighbours that, in its estimates, stand still
between messages (the reference-speed predictor holds the error), so with a strong coupling it reaches their old
average within one period while they move towards it: the sampled consensus over-shoots and, on a bipartite graph
such as the paper's 2-1-3, nearly oscillates. The same happens to any sampled-data consensus whose gain times
period is too large (Cao & Ren, "Multi-vehicle coordination for double-integrator dynamics under fixed undirected/
directed interaction in a sampled-data setting", Int. J. Robust Nonlinear Control 20(9), 2010: a gain-period
bound). Below the fastest gain, the rate is about k k2 lambda_2 / (k_zeta + k2) (the continuous loop's); above it,
it falls fast: the paper's graph with a message every 30 s decays at 0.0020 1/s with k = 0.2 and at 0.029 1/s with
k = 0.059 (tests/test_gain_schedule.py).

Chosen: among k 2^(-m/4), m = 0..16 (k down to k/16), the largest whose predicted rate is within 1 % of the best
(a rate worked out on another machine may differ in its last bits; the margin keeps the choice the same). It only
ever lowers k: with a message every step the scenario's k is kept, and the paper's ideal example is unchanged.
Applies to law (5) (corrected, literal) with a built-in predictor, whose loop the analysis models; any other law or
predictor, a scenario with `coordination.schedule = "none"`, and a loop too large to analyse quickly (more than
MAX_SCHEDULE_STATES states: many vehicles with long delays) run with k as given.
"""

from __future__ import annotations

import functools
from dataclasses import replace

from supervisor.config.stability.margins import Setting, rate

CANDIDATES = 17  # k 2^(-m/4), m = 0..16
SAME_RATE = 0.01  # rates within 1 % of the best count as equal: the largest such gain is chosen
MAX_SCHEDULE_STATES = 200  # a larger loop takes seconds per candidate: k is kept as given


@functools.lru_cache(maxsize=64)
def fastest_gain(setting: Setting) -> float:
    """The largest candidate k <= setting.loop.k whose decay rate is within SAME_RATE of the fastest. Cached: every
    vehicle of a fleet asks for it with the same setting."""
    k = setting.loop.k
    if setting.states() > MAX_SCHEDULE_STATES:
        return k
    gains = [k * 2.0 ** (-m / 4) for m in range(CANDIDATES)]
    rates = [rate(replace(setting, loop=replace(setting.loop, k=gain))) for gain in gains]
    best = max(rates)
    return next(g for g, r in zip(gains, rates, strict=True) if r >= best - SAME_RATE * abs(best))

"""The steady offset the hold predictor leaves: the forced sampled loop's periodic orbit.

The hold predictor takes a neighbour's gamma as last heard, so in the errors about the synchronised motion
(supervisor.config.stability.model: x = gamma - v_r t) each hold and each message in flight moves as
xh' = -v_r: a forcing, the same on every link, added to reference's homogeneous loop. Where that loop is stable
the fleet settles on the one periodic orbit of the forced map over a period, z -> M z + f (M the monodromy, f the
forcing's part), taken on the quotient by the consensus direction (law (5) is neutral to a common shift): there each
vehicle lags its neighbours by what its own degree and its neighbours' message ages make it, so the gammas keep a
steady spread instead of meeting, and the whole fleet runs slower than v_r (every vehicle hears its neighbours
behind where they are and slows down to wait for them).

Exact for the linear loop of the model (perfect path following, law (5) unbounded, every message delivered): a
correction bound ([saturation]) slows the approach to it, and losses, which make messages older, widen it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from supervisor.config.stability.expm import expm
from supervisor.config.stability.model import Matrix
from supervisor.config.stability.monodromy import Layout, apply_event, steps

SAMPLES_PER_FLOW = 8  # points of each flow between events at which the spread is read (its largest is the offset)
MAX_OFFSET_STATES = 200  # the orbit takes an exponential of the whole state per flow: beyond this it is not sought


@dataclass(frozen=True)
class Offset:
    """The orbit's largest spread max_ij |gamma_i - gamma_j| over a period, and the fleet's mean gamma rate on it."""

    spread: float
    rate: float


def forcing(layout: Layout, v_r: float) -> Matrix:
    """b of x' = A x + b: -v_r on every hold's and every buffer's position (the hold predictor), 0 elsewhere."""
    b = np.zeros(layout.size)
    n = layout.loop.n
    b[2 * n : layout.core : 2] = -v_r
    b[layout.core :: 2] = -v_r
    return b


def _flow(layout: Layout, b: Matrix, tau: float, kept: dict[float, Matrix]) -> Matrix:
    """exp of the affine flow over tau, as an (N + 1)-square matrix on [z, 1] (kept: by tau, a period has few)."""
    if tau not in kept:
        size = layout.size
        g = np.zeros((size + 1, size + 1))
        g[:size, :size], g[:size, size] = layout.generator, b
        kept[tau] = np.asarray(expm(g * tau))
    return kept[tau]


def _advance(layout: Layout, b: Matrix, step: tuple[str, int, float], t: Matrix, kept: dict[float, Matrix]) -> Matrix:
    """The step's affine map @ t (t acting on [z, 1]): a flow, or an event on z alone."""
    kind, j, value = step
    if kind == "flow":
        return _flow(layout, b, value, kept) @ t
    out = t.copy()
    out[: layout.size] = apply_event(layout, kind, j, value, t[: layout.size])
    return out


def steady_offset(layout: Layout, v_r: float) -> Offset | None:
    """The hold predictor's steady orbit (None: another predictor, or v_r 0: no forcing; a loop with no stable
    orbit; or one of more than MAX_OFFSET_STATES states). Law (5) corrected: the literal law settles at its own
    speed, below v_r, and its holds fall behind at that speed (a review: 1.24 predicted of a literal fleet at 0.785,
    the rate 0.54 of one at 0.28), so the scenario's analysis asks it of the corrected law only."""
    if layout.loop.predictor != "hold" or layout.size > MAX_OFFSET_STATES or v_r == 0.0:
        return None
    b, size = forcing(layout, v_r), layout.size
    kept: dict[float, Matrix] = {}
    period = np.eye(size + 1)
    for step in steps(layout):
        period = _advance(layout, b, step, period, kept)
    reduced, f, c = layout.reduced(period[:size, :size]), period[:size, size], layout.consensus
    if np.max(np.abs(np.linalg.eigvals(reduced)), initial=0.0) >= 1.0:
        return None
    orbit = np.linalg.solve(np.eye(size - 1) - reduced, f[1:] - c[1:] * f[0])
    z = np.concatenate(([0.0], orbit, [1.0]))  # the orbit's state at the period's start, x_0 = 0
    drift = float((period @ z)[0])  # x_0 a period later: the fleet's common lag
    return Offset(_spread(layout, b, z, kept), v_r + drift / layout.sampling.period)


def _spread(layout: Layout, b: Matrix, z: Matrix, kept: dict[float, Matrix]) -> float:
    """The largest max_i x_i - min_i x_i along the orbit from z over a period (each flow read at a few points)."""
    n, spread = layout.loop.n, 0.0
    for kind, j, value in steps(layout):
        parts = [value / SAMPLES_PER_FLOW] * SAMPLES_PER_FLOW if kind == "flow" else [value]
        for part in parts:
            z = _advance(layout, b, (kind, j, part), z[:, None], kept)[:, 0]
            spread = max(spread, float(np.ptp(z[:n])))
    return spread

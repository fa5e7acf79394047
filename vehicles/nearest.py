"""Where a vehicle starts along its path: the gamma of the path point nearest a position.

``closest_gamma`` searches an interval it is given. ``nearest_gamma`` takes the interval from the path itself, so
that a fleet agrees on where its vehicles start (the rule behind a scenario's ``gamma0 = "closest"``):

- a path whose course repeats every T of gamma (circle, helix: ``Path.gamma_period``) is searched over one period
  centred on a reference gamma, [reference - T/2, reference + T/2]: the nearest point of the lap nearest the
  reference. Vehicles started side by side, each searching around the same reference, then start on the same lap;
- a path that never repeats (line, lawnmower) is searched over all gamma: it runs straight outside a finite span
  (``Path.straight_beyond``), and the nearest point of a straight end lies no further along it than the point's
  distance from where that end begins;
- equally near points (within ``TIE`` relative): the one nearest the reference.

Meant for start-up, not for the hot path. Units: positions in m, gamma as the path defines it. Every distance
comes from the path's `evaluate_floats` and float or elementwise arithmetic, never numpy's trigonometry, `dot` or
`linalg.norm` (CPU-specific kernels): the gamma a vehicle starts at is the same on every machine.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from numerics.lanes import takes_lanes
from numerics.linalg import row_norms
from vehicles.bounded_min import bounded_minimum

if TYPE_CHECKING:
    from vehicles.paths import Path

__all__ = ["closest_gamma", "nearest_gamma", "search_interval"]

MAX_SPACING = 0.25  # m between the coarse samples of a search, so no local minimum is stepped over
MIN_SAMPLES = 2001
MAX_SAMPLES = 400_001  # a very long search (a line from far away) gets coarser samples, not unbounded memory
MAX_CANDIDATES = 32  # local minima refined; only a degenerate point (a circle's centre) has more
TIE = 1e-9  # relative difference in distance below which two points count as equally near


def nearest_gamma(path: Path, point: ArrayLike, reference: float = 0.0) -> float:
    """The gamma of path's point nearest to point [m, shape (3,)], searched as the module docstring says."""
    q = _point(point)
    if not math.isfinite(reference):
        raise ValueError(f"reference must be finite, got {reference!r}")
    lo, hi = search_interval(path, q, reference)
    gammas, d, spacing = _samples(path, q, lo, hi)
    # The sample nearest the true nearest point is at most spacing / 2 further from q than it: every local minimum
    # of the samples within that of the best may hold it.
    minima = _local_minima(d, float(d.min()) + spacing / 2)
    minima = sorted(minima, key=lambda i: abs(float(gammas[i]) - reference))[:MAX_CANDIDATES]
    last = gammas.size - 1
    refined = [
        closest_gamma(path, q, float(gammas[max(i - 1, 0)]), float(gammas[min(i + 1, last)]), 11) for i in minima
    ]
    refined.append(min(max(reference, lo), hi))  # wins if it is as near as any (a circle's centre: every point is)
    dist = [_distance(path, q, g) for g in refined]
    best = min(dist)
    ties = [g for g, dg in zip(refined, dist, strict=True) if dg <= best + TIE * max(best, 1.0)]
    return min(ties, key=lambda g: (abs(g - reference), g))


def search_interval(path: Path, point: NDArray[np.float64], reference: float = 0.0) -> tuple[float, float]:
    """The gammas nearest_gamma searches: one period centred on reference, or all that can hold the nearest."""
    period = path.gamma_period
    if period is not None:
        return reference - period / 2, reference + period / 2
    span = path.straight_beyond
    if span is None:
        raise ValueError(f"{path!r} neither repeats (gamma_period) nor runs straight beyond a span (straight_beyond)")
    a, b = span
    # On a straight end starting at p_d(a) with speed |dp_d/dgamma|, the nearest point is at most |q - p_d(a)| away
    # from p_d(a) along it; a little more keeps that point inside the interval.
    reach_a, reach_b = (1.001 * _distance(path, point, g) / _speed(path, g) + 1e-9 for g in (a, b))
    return a - reach_a, b + reach_b


def _point(point: ArrayLike) -> NDArray[np.float64]:
    q = np.asarray(point, dtype=np.float64)
    if q.shape != (3,):
        raise ValueError(f"point must have shape (3,), got {q.shape}")
    if not np.isfinite(q).all():
        raise ValueError(f"point must be finite, got {q!r}")
    return q


def _distance(path: Path, q: NDArray[np.float64], gamma: float) -> float:
    return math.sqrt(_dist2(path, q, gamma))


def _dist2(path: Path, q: NDArray[np.float64], gamma: float) -> float:
    p = path.evaluate_floats(gamma)[0]
    dx, dy, dz = p[0] - float(q[0]), p[1] - float(q[1]), p[2] - float(q[2])
    return dx * dx + dy * dy + dz * dz


def _speed(path: Path, gamma: float) -> float:
    dx, dy, dz = path.evaluate_floats(gamma)[1]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def _points(path: Path, gammas: NDArray[np.float64]) -> NDArray[np.float64]:
    """p_d at each gamma, shape (n, 3), from evaluate_floats: Path.positions is for plotting (numpy's kernels). A
    path that takes lanes (vehicles.lanes: the helix, circle and line) gets every gamma at once, the bits of each
    call alone (tests/test_initial_gamma.py): the paper's three starts took 24 ms gamma by gamma, 6 ms so."""
    if takes_lanes(path) and gammas.size > 1:
        with np.errstate(all="raise", under="ignore"):  # where float code would raise, or might: gamma by gamma
            try:
                every: Any = gammas  # a float's arithmetic on every gamma at once
                p = path.evaluate_floats(every)[0]
                return np.stack([np.broadcast_to(np.asarray(c, dtype=np.float64), gammas.shape) for c in p], axis=1)
            except (ArithmeticError, ValueError):
                pass
    return np.array([path.evaluate_floats(g)[0] for g in gammas.tolist()], dtype=np.float64).reshape(-1, 3)


def _samples(
    path: Path, q: NDArray[np.float64], lo: float, hi: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Gammas on [lo, hi] whose points are about MAX_SPACING apart (within the sample limits), their distances to q,
    and the largest distance [m] between consecutive points."""
    gammas = np.linspace(lo, hi, MIN_SAMPLES)
    points = _points(path, gammas)
    gaps = row_norms(np.diff(points, axis=0))
    wanted = min(max(math.ceil(math.fsum(gaps.tolist()) / MAX_SPACING) + 1, MIN_SAMPLES), MAX_SAMPLES)
    if wanted > MIN_SAMPLES:
        gammas = np.linspace(lo, hi, wanted)
        points = _points(path, gammas)
        gaps = row_norms(np.diff(points, axis=0))
    return gammas, row_norms(points - q), float(gaps.max()) if gaps.size else 0.0


def _local_minima(d: NDArray[np.float64], limit: float) -> list[int]:
    """Indices of the samples no further than their neighbours and than limit (a local minimum of the distance
    lies between the neighbours of such a sample)."""
    lower_than_left = np.concatenate(([True], d[1:] <= d[:-1]))
    lower_than_right = np.concatenate((d[:-1] <= d[1:], [True]))
    return [int(i) for i in np.nonzero(lower_than_left & lower_than_right & (d <= limit))[0]]


def closest_gamma(path: Path, point: NDArray[np.float64], lo: float, hi: float, samples: int = 2001) -> float:
    """The gamma in [lo, hi] whose p_d is nearest to point [m, shape (3,)].

    Coarse search over ``samples`` evenly spaced gammas, then a bounded scalar minimisation between the
    best sample's neighbours, then a guarded Newton polish.  Meant for start-up (choosing initial gammas),
    not for the hot path.  With several equally near points, returns one of them.
    """
    q = _checked(point, lo, hi, samples)
    if hi == lo:
        return float(lo)
    gs = np.linspace(lo, hi, samples)
    d = _points(path, gs) - q
    d2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
    i = int(np.argmin(d2))
    bracket = (float(gs[max(i - 1, 0)]), float(gs[min(i + 1, samples - 1)]))
    g = _refined(path, q, float(gs[i]), float(d2[i]), bracket)
    return _polished(path, q, g, (lo, hi), bracket[1] - bracket[0])


def _checked(point: NDArray[np.float64], lo: float, hi: float, samples: int) -> NDArray[np.float64]:
    """The point as a float array; ValueError for a bad interval, sample count or point shape."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi < lo:
        raise ValueError(f"need finite lo <= hi, got lo={lo!r}, hi={hi!r}")
    if samples < 2:
        raise ValueError(f"samples must be >= 2, got {samples!r}")
    q = np.asarray(point, dtype=np.float64)
    if q.shape != (3,):
        raise ValueError(f"point must have shape (3,), got {q.shape}")
    return q


def _refined(path: Path, q: NDArray[np.float64], g_best: float, d2_best: float, bracket: tuple[float, float]) -> float:
    """Brent's bounded minimisation (scipy's: vehicles.bounded_min) of the squared distance between the best
    sample's neighbours (bracket); the
    best sample (squared distance d2_best) if it does not do better."""

    def dist2(g: float) -> float:
        return _dist2(path, q, g)

    a, b = bracket
    # Minimise over the offset from g_best: Brent's tolerance grows with |x|, and the offset stays small.
    x = bounded_minimum(lambda t: dist2(g_best + t), a - g_best, b - g_best, 1e-12 * max(1.0, b - a))
    return g_best + x if dist2(g_best + x) <= d2_best else g_best


def _polished(path: Path, q: NDArray[np.float64], g: float, limits: tuple[float, float], width: float) -> float:
    """Newton on f'(g) = (p - q) . dp = 0: the distance is flat at the minimum, so its argmin is only resolved to
    ~sqrt(eps), while the root of f' is resolved to ~eps.  Steps are accepted only while |f'| shrinks, they stay
    within limits and are no longer than the bracket's width, so this can only polish, never wander off."""
    lo, hi = limits
    qx, qy, qz = float(q[0]), float(q[1]), float(q[2])
    p, dp, ddp = path.evaluate_floats(g)
    grad = (p[0] - qx) * dp[0] + (p[1] - qy) * dp[1] + (p[2] - qz) * dp[2]
    for _ in range(6):
        curv = (dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2]) + (
            (p[0] - qx) * ddp[0] + (p[1] - qy) * ddp[1] + (p[2] - qz) * ddp[2]
        )
        if curv <= 0.0 or grad == 0.0:
            break
        step = grad / curv
        if abs(step) > width:
            break
        g_new = min(max(g - step, lo), hi)
        p, dp, ddp = path.evaluate_floats(g_new)
        grad_new = (p[0] - qx) * dp[0] + (p[1] - qy) * dp[1] + (p[2] - qz) * dp[2]
        if abs(grad_new) >= abs(grad):
            break
        g, grad = g_new, grad_new
    return float(g)

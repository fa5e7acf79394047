"""Brent's bounded scalar minimisation, operation for operation scipy's (scipy.optimize.minimize_scalar, method
"bounded": scipy/optimize/_optimize.py, _minimize_scalar_bounded, scipy 1.17), without importing scipy.optimize.

Why not scipy itself: the initial gammas of gamma0 = "closest" (vehicles.nearest) are the only use of scipy.optimize
on a run's start-up path, and importing it took 0.22 s on an idle machine (0.5 s loaded), spent by the supervisor
before it could start a single vehicle. The same arithmetic in the same order gives the same floats:
tests/test_bounded_min.py holds it to scipy's result, bit for bit, on many functions and intervals.
"""

from __future__ import annotations

import math
from collections.abc import Callable

SQRT_EPS = math.sqrt(2.2e-16)  # scipy's constants, as scipy computes them
GOLDEN_MEAN = 0.5 * (3.0 - math.sqrt(5.0))


def _sign_or_one(v: float) -> float:
    """numpy's sign(v) + (v == 0): 1 for 0, NaN for NaN."""
    if v != v:
        return math.nan
    return -1.0 if v < 0 else 1.0


def _maximum(a: float, b: float) -> float:
    """numpy's maximum: NaN if either is."""
    if a != a or b != b:
        return math.nan
    return a if a >= b else b


def bounded_minimum(func: Callable[[float], float], lo: float, hi: float, xatol: float, maxiter: int = 500) -> float:
    """The x in [lo, hi] that minimises func, as scipy's minimize_scalar(func, bounds=(lo, hi), method="bounded",
    options={"xatol": xatol, "maxiter": maxiter}).x."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError("Optimization bounds must be finite scalars.")
    if lo > hi:
        raise ValueError("The lower bound exceeds the upper bound.")
    a, b = lo, hi
    fulc = a + GOLDEN_MEAN * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    fx = func(xf)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = SQRT_EPS * abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        rat, e = _step(xf, fx, (a, b), (nfc, fnfc, fulc, ffulc), (rat, e, tol1, tol2, xm))
        x = xf + _sign_or_one(rat) * _maximum(abs(rat), tol1)
        fu = func(x)
        num += 1
        if fu <= fx:
            a, b = (xf, b) if x >= xf else (a, xf)
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            a, b = (x, b) if x < xf else (a, x)
            if (fu <= fnfc) or (nfc == xf):
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif (fu <= ffulc) or (fulc == xf) or (fulc == nfc):  # noqa: SIM109 (`in` is `is` first: NaN)
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = SQRT_EPS * abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            break
    return xf


def _step(
    xf: float,
    fx: float,
    bounds: tuple[float, float],
    points: tuple[float, float, float, float],
    state: tuple[float, float, float, float, float],
) -> tuple[float, float]:
    """(rat, e): the next step from xf, a parabolic one where acceptable, else golden-section (scipy's loop body)."""
    a, b = bounds
    nfc, fnfc, fulc, ffulc = points
    rat, e, tol1, tol2, xm = state
    golden = True
    if abs(e) > tol1:
        golden = False
        r = (xf - nfc) * (fx - ffulc)
        q = (xf - fulc) * (fx - fnfc)
        p = (xf - fulc) * q - (xf - nfc) * r
        q = 2.0 * (q - r)
        if q > 0.0:
            p = -p
        q = abs(q)
        r = e
        e = rat
        if (abs(p) < abs(0.5 * q * r)) and (p > q * (a - xf)) and (p < q * (b - xf)):
            rat = (p + 0.0) / q
            x = xf + rat
            if ((x - a) < tol2) or ((b - x) < tol2):
                rat = tol1 * _sign_or_one(xm - xf)
        else:
            golden = True
    if golden:
        e = (a - xf) if xf >= xm else (b - xf)
        rat = GOLDEN_MEAN * e
    return rat, e

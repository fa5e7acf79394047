"""exp, expm1, exp10 and tanh ported from fdlibm (FreeBSD msun / openlibm): e_exp.c, s_expm1.c, s_tanh.c.

exp10 is not in fdlibm: exp of x*ln(10) carried as a double-double (a few ULP). Bit tests on the high word are written
as comparisons with the equivalent doubles, and 2^k as math.ldexp (exact).

Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
Developed at SunPro, a Sun Microsystems, Inc. business.
Permission to use, copy, modify, and distribute this software is freely granted, provided that this notice is
preserved.
"""

from math import fabs, inf, ldexp
from typing import Any

import numpy as np
from numpy.typing import NDArray

from numerics._bits import from_words
from numerics.lanes import FEW_LANES, each

_O_THRESHOLD = 7.09782712893383973096e02  # 0x40862E42, 0xFEFA39EF
_U_THRESHOLD = -7.45133219101941108420e02  # 0xc0874910, 0xD52D3051
_LN2_HI = 6.93147180369123816490e-01  # 0x3fe62e42, 0xfee00000
_LN2_LO = 1.90821492927058770002e-10  # 0x3dea39ef, 0x35793c76
_INVLN2 = 1.44269504088896338700e00  # 0x3ff71547, 0x652b82fe
_P1 = 1.66666666666666019037e-01  # 0x3FC55555, 0x5555553E
_P2 = -2.77777777770155933842e-03  # 0xBF66C16C, 0x16BEBD93
_P3 = 6.61375632143793436117e-05  # 0x3F11566A, 0xAF25DE2C
_P4 = -1.65339022054652515390e-06  # 0xBEBBBD41, 0xC5D26BF1
_P5 = 4.13813679705723846039e-08  # 0x3E663769, 0x72BEA4D0
_EXP_BIG = from_words(0x40862E42, 0)  # |x| >= ~709.78: overflow, underflow, inf or nan possible
_HALF_LN2 = from_words(0x3FD62E43, 0)  # |x| above: reduce (hx > 0x3fd62e42)
_THREE_HALVES_LN2 = from_words(0x3FF0A2B2, 0)  # |x| below: k = +-1
_TWO_M28 = from_words(0x3E300000, 0)  # 2^-28


def _reduce_ln2(x: float) -> tuple[int, float, float]:
    """(k, hi, lo) with x = k*ln2 + (hi - lo), |hi - lo| <= ln2/2, for |x| > ln2/2 (e_exp.c, s_expm1.c)."""
    if fabs(x) < _THREE_HALVES_LN2:
        if x > 0.0:
            return 1, x - _LN2_HI, _LN2_LO
        return -1, x + _LN2_HI, -_LN2_LO
    k = int(_INVLN2 * x + (0.5 if x > 0.0 else -0.5))
    t = float(k)
    return k, x - t * _LN2_HI, t * _LN2_LO  # t*LN2_HI is exact here


def exp(x: float) -> float:
    """e^x (e_exp.c); exp(+inf) = inf, exp(-inf) = 0, inf on overflow, 0 on underflow."""
    ax = fabs(x)
    if not ax < _EXP_BIG:
        if x != x:
            return x
        if x > _O_THRESHOLD:
            return inf
        if x < _U_THRESHOLD:
            return 0.0
    if x == 1.0:  # e_exp.c: the nearest double rather than 2.7182818284590455
        return 2.718281828459045235360
    if ax > _HALF_LN2:
        k, hi, lo = _reduce_ln2(x)
        x = hi - lo
    elif ax < _TWO_M28:
        return 1.0 + x
    else:
        k, hi, lo = 0, 0.0, 0.0
    t = x * x
    c = x - t * (_P1 + t * (_P2 + t * (_P3 + t * (_P4 + t * _P5))))
    if k == 0:
        return 1.0 - ((x * c) / (c - 2.0) - x)
    y = 1.0 - ((lo - (x * c) / (2.0 - c)) - hi)
    return ldexp(y, k)  # y*2^k with one rounding if subnormal, as y*twopk*twom1000


# s_expm1.c
_Q1 = -3.33333333333331316428e-02  # BFA11111 111110F4
_Q2 = 1.58730158725481460165e-03  # 3F5A01A0 19FE5585
_Q3 = -7.93650757867487942473e-05  # BF14CE19 9EAADBB7
_Q4 = 4.00821782732936239552e-06  # 3ED0CFCA 86E65239
_Q5 = -2.01099218183624371326e-07  # BE8AFDB7 6E09C32D
_EXPM1_BIG = from_words(0x4043687A, 0)  # 56*ln2
_TWO_M54 = from_words(0x3C900000, 0)  # 2^-54


def expm1(x: float) -> float:
    """e^x - 1, accurate near 0 (s_expm1.c); expm1(-inf) = -1."""
    ax = fabs(x)
    if not ax < _EXPM1_BIG:
        if x != x:
            return x
        if x > _O_THRESHOLD:
            return inf
        if x < 0.0:
            return -1.0
    if ax > _HALF_LN2:
        k, hi, lo = _reduce_ln2(x)
        x = hi - lo
        c = (hi - x) - lo
    elif ax < _TWO_M54:
        return x
    else:
        k, c = 0, 0.0
    hfx = 0.5 * x
    hxs = x * hfx
    r1 = 1.0 + hxs * (_Q1 + hxs * (_Q2 + hxs * (_Q3 + hxs * (_Q4 + hxs * _Q5))))
    t = 3.0 - r1 * hfx
    e = hxs * ((r1 - t) / (6.0 - x * t))
    if k == 0:
        return x - (x * e - hxs)  # c is 0
    return _expm1_scale(k, x, (x * (e - c) - c) - hxs)


def _expm1_scale(k: int, x: float, e: float) -> float:
    """2^k*(1 + x - e) - 1 without cancellation, the end of s_expm1.c for k != 0."""
    if k == -1:
        return 0.5 * (x - e) - 0.5
    if k == 1:
        if x < -0.25:
            return -2.0 * (e - (x + 0.5))
        return 1.0 + 2.0 * (x - e)
    if k <= -2 or k > 56:  # suffices to return exp(x) - 1
        y = 1.0 - (e - x)
        y = y * 2.0 * 8.98846567431158e307 if k == 1024 else y * ldexp(1.0, k)
        return y - 1.0
    if k < 20:
        y = (1.0 - ldexp(1.0, -k)) - (e - x)  # t = 1 - 2^-k
    else:
        y = x - (e + ldexp(1.0, -k))
        y += 1.0
    return y * ldexp(1.0, k)


# s_tanh.c
_TANH_BIG = from_words(0x40360000, 0)  # 22


def tanh(x: float) -> float:
    """Hyperbolic tangent (s_tanh.c); tanh(+-inf) = +-1. x may be a numpy array of lanes (vehicles.lanes): then the
    same, lane by lane."""
    if isinstance(x, np.ndarray):
        return _tanh_lanes(x) if x.size >= FEW_LANES else each(tanh, x)
    ax = fabs(x)
    if not ax < _TANH_BIG:
        if x != x:
            return x
        z = 1.0
    elif ax < _TWO_M28:
        return x
    elif ax >= 1.0:
        t = expm1(2.0 * ax)
        z = 1.0 - 2.0 / (t + 2.0)
    else:
        t = expm1(-2.0 * ax)
        z = -t / (t + 2.0)
    return -z if x < 0.0 else z


def _tanh_lanes(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """tanh of each lane: s_tanh.c's branches chosen by where, the usual ones (2^-28 <= |x| < 22) on arrays through
    _expm1_lanes, each on a stand-in (0.5) where the lane is elsewhere."""
    ax = np.abs(x)
    usual = (ax >= _TWO_M28) & (ax < _TANH_BIG)
    a = np.where(usual, ax, 0.5)
    big = a >= 1.0
    t = _expm1_lanes(np.where(big, 2.0 * a, -2.0 * a))
    z = np.where(big, 1.0 - 2.0 / (t + 2.0), -t / (t + 2.0))
    edge = np.where((ax < _TWO_M28) | (x != x), x, np.where(x < 0.0, -1.0, 1.0))  # x itself; +-1 past 22
    return np.where(usual, np.where(x < 0.0, -z, z), edge)


def _expm1_lanes(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """expm1 of each lane, 2^-54 <= |x| < 56 ln2 (s_expm1.c, its reduction and scaling branches chosen by where)."""
    ax = np.abs(x)
    reduce = ax > _HALF_LN2
    near = ax < _THREE_HALVES_LN2
    k_far = np.trunc(_INVLN2 * x + np.where(x > 0.0, 0.5, -0.5))
    k = np.where(reduce, np.where(near, np.where(x > 0.0, 1.0, -1.0), k_far), 0.0)
    hi = np.where(near, np.where(x > 0.0, x - _LN2_HI, x + _LN2_HI), x - k * _LN2_HI)
    lo = np.where(near, np.where(x > 0.0, _LN2_LO, -_LN2_LO), k * _LN2_LO)
    xr = np.where(reduce, hi - lo, x)
    c = np.where(reduce, (hi - xr) - lo, 0.0)
    hfx = 0.5 * xr
    hxs = xr * hfx
    r1 = 1.0 + hxs * (_Q1 + hxs * (_Q2 + hxs * (_Q3 + hxs * (_Q4 + hxs * _Q5))))
    t = 3.0 - r1 * hfx
    e = hxs * ((r1 - t) / (6.0 - xr * t))
    return np.where(k == 0.0, xr - (xr * e - hxs), _expm1_scale_lanes(k, xr, (xr * (e - c) - c) - hxs))


def _expm1_scale_lanes(k: NDArray[np.float64], x: NDArray[np.float64], e: NDArray[np.float64]) -> Any:
    """_expm1_scale of each lane (k < 64: no 2^1024)."""
    two_k, two_minus_k = np.ldexp(1.0, k.astype(np.int64)), np.ldexp(1.0, -k.astype(np.int64))
    return np.select(
        [k == -1.0, (k == 1.0) & (x < -0.25), k == 1.0, (k <= -2.0) | (k > 56.0), k < 20.0],
        [
            0.5 * (x - e) - 0.5,
            -2.0 * (e - (x + 0.5)),
            1.0 + 2.0 * (x - e),
            (1.0 - (e - x)) * two_k - 1.0,
            ((1.0 - two_minus_k) - (e - x)) * two_k,
        ],
        ((x - (e + two_minus_k)) + 1.0) * two_k,
    )


# exp10: x*ln(10) as a double-double, then exp(hi)*(1 + lo).
_LN10_HI = 2.302585092994046  # 0x40026BB1, 0xBBB55516
_LN10_LO = -2.1707562233822494e-16  # 0xBCAF48AD, 0x494EA3E9: ln(10) - LN10_HI, rounded
_SPLIT = 134217729.0  # 2^27 + 1, Veltkamp's splitter
_POWERS_OF_TEN = (  # 10^0 .. 10^22, all exact doubles
    1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11,
    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
)  # fmt: skip


def _two_product(a: float, b: float) -> tuple[float, float]:
    """(p, e) with p = fl(a*b) and p + e = a*b exactly (Dekker, Veltkamp's split; no FMA)."""
    p = a * b
    t = _SPLIT * a
    a_hi = t - (t - a)
    a_lo = a - a_hi
    t = _SPLIT * b
    b_hi = t - (t - b)
    b_lo = b - b_hi
    return p, ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo


def exp10(x: float) -> float:
    """10^x within a few ULP; exact for the integers 0..22 (not in fdlibm)."""
    if x != x:
        return x
    if 0.0 <= x <= 22.0 and x == int(x):
        return _POWERS_OF_TEN[int(x)]
    if x > 300.0:  # keep exp(hi) clear of overflow where 10^x is still finite
        if x > 310.0:
            return inf
        return exp10(x - 8.0) * 1e8  # x - 8 is exact here
    if x < -330.0:
        return 0.0
    hi, lo = _two_product(x, _LN10_HI)
    lo += x * _LN10_LO
    e = exp(hi)
    return e + e * lo

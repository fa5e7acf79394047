"""log, log1p and log10 ported from fdlibm (FreeBSD msun / openlibm): e_log.c, s_log1p.c, e_log10.c, k_log.h.

fdlibm's tests on the high word's exponent and mantissa bits are math.frexp and comparisons with the equivalent
doubles here (the same branches).
log(0) = -inf and log(x < 0) = nan, as in C (Python's math raises ValueError).

Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
Developed at SunPro, a Sun Microsystems, Inc. business.
Permission to use, copy, modify, and distribute this software is freely granted, provided that this notice is
preserved.
"""

from math import fabs, frexp, inf, nan

from numerics._bits import clear_low_word, from_words

_LN2_HI = 6.93147180369123816490e-01  # 3fe62e42 fee00000
_LN2_LO = 1.90821492927058770002e-10  # 3dea39ef 35793c76
_TWO54 = 1.80143985094819840000e16  # 43500000 00000000
_LG1 = 6.666666666666735130e-01  # 3FE55555 55555593
_LG2 = 3.999999999940941908e-01  # 3FD99999 9997FA04
_LG3 = 2.857142874366239149e-01  # 3FD24924 94229359
_LG4 = 2.222219843214978396e-01  # 3FCC71C5 1D8E78AF
_LG5 = 1.818357216161805012e-01  # 3FC74664 96CB03DE
_LG6 = 1.531383769920937332e-01  # 3FC39A09 D078C69F
_LG7 = 1.479819860511658591e-01  # 3FC2F112 DF3E5244
_SQRT2_SPLIT = from_words(0x3FF6A09C, 0)  # m in [1, 2) at or above: use m/2 ((hx + 0x95f64) & 0x100000)
_ONE_PLUS = from_words(0x3FF00001, 0)  # 1 + 2^-20
_TWO_MINUS = from_words(0x3FFFFFFE, 0)  # 2 - 2^-19
_CLOSE_LOW = from_words(0x3FF6147A, 0)  # hx - 0x6147a >= 0
_CLOSE_HIGH = from_words(0x3FF6B852, 0)  # 0x6b851 - hx >= 0


def _split(x: float) -> tuple[int, float, float]:
    """(k, m, m1): x = 2^k*m, m in [sqrt(2)/2, sqrt(2)); m1 in [1, 2) the mantissa of x (e_log.c, with frexp).

    fdlibm reads m1's high word; its tests on those bits are comparisons of m1 with the equivalent doubles here.
    """
    mantissa, exponent = frexp(x)  # exact, subnormals included
    m1 = mantissa * 2.0
    if m1 >= _SQRT2_SPLIT:
        return exponent, mantissa, m1
    return exponent - 1, m1, m1


def log(x: float) -> float:
    """Natural logarithm (e_log.c); log(0) = -inf, log(x < 0) = nan."""
    if not 0.0 < x < inf:
        if x == 0.0:
            return -inf
        return x if x == inf or x != x else nan
    k, m, m1 = _split(x)
    f = m - 1.0
    dk = float(k)
    if m1 < _ONE_PLUS or m1 >= _TWO_MINUS:  # -2^-20 <= f < 2^-20
        if f == 0.0:
            return 0.0 if k == 0 else dk * _LN2_HI + dk * _LN2_LO
        r = f * f * (0.5 - 0.33333333333333333 * f)
        return f - r if k == 0 else dk * _LN2_HI - ((r - dk * _LN2_LO) - f)
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    r = t2 + t1
    if _CLOSE_LOW <= m1 < _CLOSE_HIGH:  # ((hx - 0x6147a) | (0x6b851 - hx)) > 0
        hfsq = 0.5 * f * f
        if k == 0:
            return f - (hfsq - s * (hfsq + r))
        return dk * _LN2_HI - ((hfsq - (s * (hfsq + r) + dk * _LN2_LO)) - f)
    if k == 0:
        return f - s * (f - r)
    return dk * _LN2_HI - ((s * (f - r) - dk * _LN2_LO) - f)


_LOG1P_SMALL = from_words(0x3FDA827A, 0)  # 1 + x < sqrt(2)+ below
_LOG1P_NEG = from_words(0x3FD2BEC5, 0)  # -x below: sqrt(2)/2- <= 1 + x (hx <= 0xbfd2bec4)
_TWO_M29 = from_words(0x3E200000, 0)
_TWO_M54 = from_words(0x3C900000, 0)
_U_SPLIT = from_words(0x3FF6A09E, 0)  # u ~< sqrt(2) below
_U_TWO_MINUS = from_words(0x3FFFFFFD, 0)  # (0x00100000 - hu) >> 2 == 0 at or above


def _log1p_split(x: float) -> tuple[int, float, float, bool]:
    """(k, f, c, tiny): 1 + x = 2^k*(1 + f + c), c the rounding error of 1 + x, tiny: |f| < 2^-20 (s_log1p.c)."""
    if x < 9007199254740992.0:  # hx < 0x43400000: 2^53
        u = 1.0 + x
        mantissa, exponent = frexp(u)
        c = (1.0 - (u - x) if exponent > 1 else x - (u - 1.0)) / u  # correction term
    else:
        mantissa, exponent = frexp(x)
        c = 0.0
    u1 = mantissa * 2.0  # in [1, 2)
    k = exponent - 1
    if u1 < _U_SPLIT:
        return k, u1 - 1.0, c, u1 < _ONE_PLUS
    return k + 1, mantissa - 1.0, c, u1 >= _U_TWO_MINUS


def log1p(x: float) -> float:
    """log(1 + x), accurate near 0 (s_log1p.c); log1p(-1) = -inf, log1p(x < -1) = nan."""
    if not -1.0 < x < inf:
        if x == -1.0:
            return -inf
        return x if x == inf or x != x else nan
    if x < _LOG1P_SMALL:  # 1 + x < sqrt(2)+
        ax = fabs(x)
        if ax < _TWO_M29:
            return x if ax < _TWO_M54 else x - x * x * 0.5
    if x < _LOG1P_SMALL and (x > 0.0 or x > -_LOG1P_NEG):  # sqrt(2)/2- <= 1 + x < sqrt(2)+
        k, f, c, tiny = 0, x, 0.0, False
    else:
        k, f, c, tiny = _log1p_split(x)
    hfsq = 0.5 * f * f
    if tiny:  # |f| < 2^-20
        if f == 0.0:
            return 0.0 if k == 0 else k * _LN2_HI + (c + k * _LN2_LO)
        r = hfsq * (1.0 - 0.66666666666666666 * f)
        return f - r if k == 0 else k * _LN2_HI - ((r - (k * _LN2_LO + c)) - f)
    s = f / (2.0 + f)
    z = s * s
    r = z * (_LG1 + z * (_LG2 + z * (_LG3 + z * (_LG4 + z * (_LG5 + z * (_LG6 + z * _LG7))))))
    if k == 0:
        return f - (hfsq - s * (hfsq + r))
    return k * _LN2_HI - ((hfsq - (s * (hfsq + r) + (k * _LN2_LO + c))) - f)


# e_log10.c
_IVLN10HI = 4.34294481878168880939e-01  # 0x3fdbcb7b, 0x15200000
_IVLN10LO = 2.50829467116452752298e-11  # 0x3dbb9438, 0xca9aadd5
_LOG10_2HI = 3.01029995663611771306e-01  # 0x3FD34413, 0x509F6000
_LOG10_2LO = 3.69423907715893078616e-13  # 0x3D59FEF3, 0x11F12B36


def _k_log1p(f: float) -> float:
    """log(1 + f) - f + f*f/2 for f in [sqrt(2)/2 - 1, sqrt(2) - 1] (k_log.h)."""
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    hfsq = 0.5 * f * f
    return s * (hfsq + (t2 + t1))


def log10(x: float) -> float:
    """Base-10 logarithm (e_log10.c); log10(0) = -inf, log10(x < 0) = nan."""
    if not 0.0 < x < inf:
        if x == 0.0:
            return -inf
        return x if x == inf or x != x else nan
    if x == 1.0:
        return 0.0
    k, m, _ = _split(x)
    y = float(k)
    f = m - 1.0
    hfsq = 0.5 * f * f
    r = _k_log1p(f)
    hi = clear_low_word(f - hfsq)
    lo = (f - hi) - hfsq + r
    val_hi = hi * _IVLN10HI
    y2 = y * _LOG10_2HI
    val_lo = y * _LOG10_2LO + (lo + hi) * _IVLN10LO + lo * _IVLN10HI
    w = y2 + val_hi
    val_lo += (y2 - w) + val_hi
    return val_lo + w

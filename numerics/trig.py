"""sin, cos, sincos, atan, atan2 and asin ported from fdlibm (FreeBSD msun / openlibm).

Ports k_sin.c, k_cos.c, s_sin.c, s_cos.c, s_atan.c, e_atan2.c and e_asin.c; the argument reduction is in
numerics._reduce (e_rem_pio2.c). Bit tests on the high word are written as comparisons with the equivalent doubles.

Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
Developed at SunPro, a Sun Microsystems, Inc. business.
Permission to use, copy, modify, and distribute this software is freely granted, provided that this notice is
preserved.
"""

from math import copysign, fabs, frexp, inf, nan, sqrt

import numpy as np
from numpy.typing import NDArray

from numerics._bits import clear_low_word, from_words
from numerics._reduce import _INVPIO2, _PIO2_1, _PIO2_1T, _TO_INT, _TWO_M16, MEDIUM_LIMIT, rem_pio2
from numerics.lanes import FEW_LANES, each

# k_sin.c
_S1 = -1.66666666666666324348e-01  # 0xBFC55555, 0x55555549
_S2 = 8.33333333332248946124e-03  # 0x3F811111, 0x1110F8A6
_S3 = -1.98412698298579493134e-04  # 0xBF2A01A0, 0x19C161D5
_S4 = 2.75573137070700676789e-06  # 0x3EC71DE3, 0x57B1FE7D
_S5 = -2.50507602534068634195e-08  # 0xBE5AE5E6, 0x8A2B9CEB
_S6 = 1.58969099521155010221e-10  # 0x3DE5D93A, 0x5ACFD57C
# k_cos.c
_C1 = 4.16666666666666019037e-02  # 0x3FA55555, 0x5555554C
_C2 = -1.38888888888741095749e-03  # 0xBF56C16C, 0x16C15177
_C3 = 2.48015872894767294178e-05  # 0x3EFA01A0, 0x19CB1590
_C4 = -2.75573143513906633035e-07  # 0xBE927E4F, 0x809C52AD
_C5 = 2.08757232129817482790e-09  # 0x3E21EE9E, 0xBDB4B1C4
_C6 = -1.13596475577881948265e-11  # 0xBDA8FAE9, 0xBE8838D4

_PIO4_HIGH = from_words(0x3FE921FC, 0)  # |x| < this: |x| ~<= pi/4, no reduction (ix <= 0x3fe921fb)
_SIN_TINY = from_words(0x3E500000, 0)  # 2^-26: sin(x) = x below
_COS_TINY = from_words(0x3E46A09E, 0)  # 2^-27*sqrt(2): cos(x) = 1 below


def _kernel_sin(x: float, y: float) -> float:
    """sin(x + y) for |x + y| <~ pi/4, y the tail of x (k_sin.c, __kernel_sin with iy = 1)."""
    z = x * x
    w = z * z
    r = _S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)
    v = z * x
    return x - ((z * (0.5 * y - v * r) - y) - v * _S1)


def _kernel_sin0(x: float) -> float:
    """sin(x) for |x| <~ pi/4 (k_sin.c, __kernel_sin with iy = 0)."""
    z = x * x
    w = z * z
    r = _S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)
    return x + z * x * (_S1 + z * r)


def _kernel_cos(x: float, y: float) -> float:
    """cos(x + y) for |x + y| <~ pi/4, y the tail of x (k_cos.c, __kernel_cos)."""
    z = x * x
    w = z * z
    r = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    w = 1.0 - hz
    return w + (((1.0 - w) - hz) + (z * r - x * y))


def sin(x: float) -> float:
    """Sine of x (s_sin.c); sin(+-inf) = nan."""
    if -_PIO4_HIGH < x < _PIO4_HIGH:
        if -_SIN_TINY < x < _SIN_TINY:
            return x
        return _kernel_sin0(x)
    if x - x != 0.0:  # inf or nan
        return nan if x == x else x
    n, y0, y1 = rem_pio2(x)
    n &= 3
    if n == 0:
        return _kernel_sin(y0, y1)
    if n == 1:
        return _kernel_cos(y0, y1)
    if n == 2:
        return -_kernel_sin(y0, y1)
    return -_kernel_cos(y0, y1)


def cos(x: float) -> float:
    """Cosine of x (s_cos.c); cos(+-inf) = nan. x may be a numpy array of lanes: sincos's cosine of each."""
    if isinstance(x, np.ndarray):
        return _sincos_lanes(x)[1] if x.size >= FEW_LANES else each(cos, x)
    if -_PIO4_HIGH < x < _PIO4_HIGH:
        if -_COS_TINY < x < _COS_TINY:
            return 1.0
        return _kernel_cos(x, 0.0)
    if x - x != 0.0:  # inf or nan
        return nan if x == x else x
    n, y0, y1 = rem_pio2(x)
    n &= 3
    if n == 0:
        return _kernel_cos(y0, y1)
    if n == 1:
        return -_kernel_sin(y0, y1)
    if n == 2:
        return -_kernel_cos(y0, y1)
    return _kernel_sin(y0, y1)


def sincos(x: float) -> tuple[float, float]:
    """(sin(x), cos(x)) with one argument reduction; the same bits as sin(x) and cos(x). x may be a numpy array of
    lanes (vehicles.lanes): then the same, lane by lane."""
    if isinstance(x, np.ndarray):
        if x.size >= FEW_LANES:
            return _sincos_lanes(x)
        s, c = zip(*map(sincos, x.tolist()), strict=True) if x.size else ((), ())
        return np.array(s, dtype=np.float64), np.array(c, dtype=np.float64)
    if -_PIO4_HIGH < x < _PIO4_HIGH:
        s = x if -_SIN_TINY < x < _SIN_TINY else _kernel_sin0(x)
        c = 1.0 if -_COS_TINY < x < _COS_TINY else _kernel_cos(x, 0.0)
        return s, c
    if x - x != 0.0:  # inf or nan
        value = nan if x == x else x
        return value, value
    n, y0, y1 = rem_pio2(x)
    s = _kernel_sin(y0, y1)
    c = _kernel_cos(y0, y1)
    n &= 3
    if n == 0:
        return s, c
    if n == 1:
        return c, -s
    if n == 2:
        return -s, -c
    return -c, s


def _sincos_lanes(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """sincos of each lane, its arithmetic on arrays where it takes no branch on the lane (|x| < pi/4, and the
    medium reduction's first round, which is all but |x| near a multiple of pi/2 needs); the other lanes (those,
    huge, inf or nan) through the scalar code. Lanes headed elsewhere compute on stand-ins (0, 1): no float error."""
    ax = np.abs(x)
    small = ax < _PIO4_HIGH
    medium = ~small & (ax < MEDIUM_LIMIT)
    xm = np.where(medium, x, 1.0)
    fn = (xm * _INVPIO2 + _TO_INT) - _TO_INT
    r = xm - fn * _PIO2_1
    w = fn * _PIO2_1T
    y0 = r - w
    medium &= ~(np.abs(y0) < np.abs(xm) * _TWO_M16)  # rem_pio2's second round: the scalar code
    y1 = (r - y0) - w
    xs = np.where(small, x, 0.0)
    s_small = np.where(np.abs(xs) < _SIN_TINY, xs, _kernel_sin0(xs))  # type: ignore[arg-type]
    c_small = np.where(np.abs(xs) < _COS_TINY, 1.0, _kernel_cos(xs, 0.0))  # type: ignore[arg-type]
    s_m, c_m = _kernel_sin(y0, y1), _kernel_cos(y0, y1)  # type: ignore[arg-type]
    n = fn.astype(np.int64) & 3
    s = np.where(small, s_small, np.choose(n, [s_m, c_m, -s_m, -c_m]))
    c = np.where(small, c_small, np.choose(n, [c_m, -s_m, -c_m, s_m]))
    for i in np.flatnonzero(~(small | medium)).tolist():
        s[i], c[i] = sincos(float(x[i]))
    return s, c


# s_atan.c: atan(0.5), atan(1), atan(1.5), atan(inf) as high and low parts, and the odd polynomial.
_ATANHI = (
    4.63647609000806093515e-01,  # 0x3FDDAC67, 0x0561BB4F
    7.85398163397448278999e-01,  # 0x3FE921FB, 0x54442D18
    9.82793723247329054082e-01,  # 0x3FEF730B, 0xD281F69B
    1.57079632679489655800e00,  # 0x3FF921FB, 0x54442D18
)
_ATANLO = (
    2.26987774529616870924e-17,  # 0x3C7A2B7F, 0x222F65E2
    3.06161699786838301793e-17,  # 0x3C81A626, 0x33145C07
    1.39033110312309984516e-17,  # 0x3C700788, 0x7AF0CBBD
    6.12323399573676603587e-17,  # 0x3C91A626, 0x33145C07
)
_AT0, _AT1, _AT2, _AT3, _AT4, _AT5, _AT6, _AT7, _AT8, _AT9, _AT10 = (
    3.33333333333329318027e-01,  # 0x3FD55555, 0x5555550D
    -1.99999999998764832476e-01,  # 0xBFC99999, 0x9998EBC4
    1.42857142725034663711e-01,  # 0x3FC24924, 0x920083FF
    -1.11111104054623557880e-01,  # 0xBFBC71C6, 0xFE231671
    9.09088713343650656196e-02,  # 0x3FB745CD, 0xC54C206E
    -7.69187620504482999495e-02,  # 0xBFB3B0F2, 0xAF749A6D
    6.66107313738753120669e-02,  # 0x3FB10D66, 0xA0D03D51
    -5.83357013379057348645e-02,  # 0xBFADDE2D, 0x52DEFD9A
    4.97687799461593236017e-02,  # 0x3FA97B4B, 0x24760DEB
    -3.65315727442169155270e-02,  # 0xBFA2B444, 0x2C6A6C2F
    1.62858201153657823623e-02,  # 0x3F90AD3A, 0xE322DA11
)
_ATAN_BIG = from_words(0x44100000, 0)  # 2^66
_ATAN_TINY = from_words(0x3E400000, 0)  # 2^-27


def _atan_poly(x: float) -> float:
    """sum aT[i]*x^(2i+2) split in odd and even parts (s_atan.c)."""
    z = x * x
    w = z * z
    s1 = z * (_AT0 + w * (_AT2 + w * (_AT4 + w * (_AT6 + w * (_AT8 + w * _AT10)))))
    s2 = w * (_AT1 + w * (_AT3 + w * (_AT5 + w * (_AT7 + w * _AT9))))
    return s1 + s2


def atan(x: float) -> float:
    """Arc tangent of x in [-pi/2, pi/2] (s_atan.c)."""
    ax = fabs(x)
    if not ax < _ATAN_BIG:  # |x| >= 2^66 or nan
        return x if x != x else copysign(_ATANHI[3] + _ATANLO[3], x)
    if ax < 0.4375:
        return x if ax < _ATAN_TINY else x - x * _atan_poly(x)
    if ax < 1.1875:
        if ax < 0.6875:
            i, t = 0, (2.0 * ax - 1.0) / (2.0 + ax)
        else:
            i, t = 1, (ax - 1.0) / (ax + 1.0)
    elif ax < 2.4375:
        i, t = 2, (ax - 1.5) / (1.0 + 1.5 * ax)
    else:
        i, t = 3, -1.0 / ax
    z = _ATANHI[i] - ((t * _atan_poly(t) - _ATANLO[i]) - t)
    return -z if x < 0.0 else z


# e_atan2.c
_PI_O_4 = 7.8539816339744827900e-01  # 0x3FE921FB, 0x54442D18
_PI_O_2 = 1.5707963267948965580e00  # 0x3FF921FB, 0x54442D18
_PI = 3.1415926535897931160e00  # 0x400921FB, 0x54442D18
_PI_LO = 1.2246467991473531772e-16  # 0x3CA1A626, 0x33145C07


def atan2(y: float, x: float) -> float:
    """Arc tangent of y/x in [-pi, pi] using the signs of both (e_atan2.c); atan2(+-0, -0) = +-pi. y and x may be
    numpy arrays of lanes (vehicles.lanes): then the same, lane by lane."""
    if isinstance(y, np.ndarray) or isinstance(x, np.ndarray):
        lanes = (np.asarray(y, dtype=np.float64), np.asarray(x, dtype=np.float64))
        return _atan2_lanes(*lanes) if max(a.size for a in lanes) >= FEW_LANES else each(atan2, *lanes)
    if x != x or y != y:
        return x + y
    if x == 1.0:
        return atan(y)
    m = (2 if copysign(1.0, x) < 0.0 else 0) + (1 if copysign(1.0, y) < 0.0 else 0)  # 2*sign(x) + sign(y)
    if y == 0.0:
        return (y, y, _PI, -_PI)[m]
    if x == 0.0:
        return -_PI_O_2 if y < 0.0 else _PI_O_2
    if fabs(x) == inf:
        if fabs(y) == inf:
            return (_PI_O_4, -_PI_O_4, 3.0 * _PI_O_4, -3.0 * _PI_O_4)[m]
        return (0.0, -0.0, _PI, -_PI)[m]
    if fabs(y) == inf:
        return -_PI_O_2 if y < 0.0 else _PI_O_2
    k = frexp(y)[1] - frexp(x)[1]
    if k > 60:  # |y/x| > 2^60
        z = _PI_O_2 + 0.5 * _PI_LO
        m &= 1
    elif x < 0.0 and k < -60:  # 0 > |y|/x > -2^-60
        z = 0.0
    else:
        z = atan(fabs(y / x))
    if m == 0:
        return z
    if m == 1:
        return -z
    if m == 2:
        return _PI - (z - _PI_LO)
    return (z - _PI_LO) - _PI


def _atan2_lanes(y: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """atan2 of each pair of lanes, on arrays where e_atan2.c's path is atan(|y/x|) with both finite and nonzero and
    x not 1 (all but a few lanes of a vehicle's angles), the scalar code for the others. Lanes headed elsewhere
    compute on a stand-in (1, the ratio 1): no float error."""
    y, x = np.broadcast_arrays(y, x)
    k = np.frexp(y)[1] - np.frexp(x)[1]
    usual = np.isfinite(x) & np.isfinite(y) & (x != 0.0) & (y != 0.0) & (x != 1.0) & (k <= 60)
    usual &= ~((x < 0.0) & (k < -60))
    ratio = np.abs(np.where(usual, y, 1.0) / np.where(usual, x, 1.0))
    usual &= ratio != 0.0  # y/x underflowed: the scalar code (atan of 0 or a subnormal)
    z = _atan_lanes(np.where(usual, ratio, 1.0))
    z = np.where(y < 0.0, np.where(x < 0.0, (z - _PI_LO) - _PI, -z), np.where(x < 0.0, _PI - (z - _PI_LO), z))
    out = np.array(z, dtype=np.float64)
    for i in np.flatnonzero(~usual).tolist():
        out.flat[i] = atan2(float(y.flat[i]), float(x.flat[i]))
    return out


def _atan_lanes(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """atan of each lane of a, 0 < a < 2^61 (s_atan.c's branches, each lane's own by where): every interval's
    reduction is computed for every lane, on a stand-in where the lane is elsewhere."""
    tiny = a < _ATAN_TINY
    low = a < 0.4375
    i = (a >= 0.6875).astype(np.int64) + (a >= 1.1875) + (a >= 2.4375)
    far = np.where(i == 3, a, 2.5)  # -1/a only where a is that large: no overflow elsewhere
    t = np.choose(i, [(2.0 * a - 1.0) / (2.0 + a), (a - 1.0) / (a + 1.0), (a - 1.5) / (1.0 + 1.5 * a), -1.0 / far])
    hi, lo = np.choose(i, _ATANHI), np.choose(i, _ATANLO)
    t = np.where(low, 0.5, t)
    reduced = hi - ((t * _atan_poly(t) - lo) - t)  # type: ignore[arg-type]
    near = np.where(low & ~tiny, a, 0.5)
    return np.where(low, np.where(tiny, a, near - near * _atan_poly(near)), reduced)  # type: ignore[arg-type]


# e_asin.c
_PIO2_HI = 1.57079632679489655800e00  # 0x3FF921FB, 0x54442D18
_PIO2_LO = 6.12323399573676603587e-17  # 0x3C91A626, 0x33145C07
_PIO4_HI = 7.85398163397448278999e-01  # 0x3FE921FB, 0x54442D18
_PS0 = 1.66666666666666657415e-01  # 0x3FC55555, 0x55555555
_PS1 = -3.25565818622400915405e-01  # 0xBFD4D612, 0x03EB6F7D
_PS2 = 2.01212532134862925881e-01  # 0x3FC9C155, 0x0E884455
_PS3 = -4.00555345006794114027e-02  # 0xBFA48228, 0xB5688F3B
_PS4 = 7.91534994289814532176e-04  # 0x3F49EFE0, 0x7501B288
_PS5 = 3.47933107596021167570e-05  # 0x3F023DE1, 0x0DFDF709
_QS1 = -2.40339491173441421878e00  # 0xC0033A27, 0x1C8A2D4B
_QS2 = 2.02094576023350569471e00  # 0x40002AE5, 0x9C598AC8
_QS3 = -6.88283971605453293030e-01  # 0xBFE6066C, 0x1B8D0159
_QS4 = 7.70381505559019352791e-02  # 0x3FB3B8C5, 0xB12E9282
_ASIN_NEAR_ONE = from_words(0x3FEF3333, 0)  # ~0.975


def _asin_ratio(t: float) -> float:
    """R(t) = p(t)/q(t), the rational approximation of e_asin.c."""
    p = t * (_PS0 + t * (_PS1 + t * (_PS2 + t * (_PS3 + t * (_PS4 + t * _PS5)))))
    q = 1.0 + t * (_QS1 + t * (_QS2 + t * (_QS3 + t * _QS4)))
    return p / q


def asin(x: float) -> float:
    """Arc sine of x in [-pi/2, pi/2] (e_asin.c); nan for |x| > 1."""
    ax = fabs(x)
    if not ax < 1.0:
        if ax == 1.0:
            return x * _PIO2_HI + x * _PIO2_LO
        return x if x != x else nan
    if ax < 0.5:
        if ax < _SIN_TINY:
            return x
        return x + x * _asin_ratio(x * x)
    t = (1.0 - ax) * 0.5
    r = _asin_ratio(t)
    s = sqrt(t)
    if ax >= _ASIN_NEAR_ONE:
        t = _PIO2_HI - (2.0 * (s + s * r) - _PIO2_LO)
    else:
        w = clear_low_word(s)
        c = (t - w * w) / (s + w)
        p = 2.0 * s * r - (_PIO2_LO - 2.0 * c)
        q = _PIO4_HI - 2.0 * w
        t = _PIO4_HI - (p - q)
    return t if x > 0.0 else -t

"""Argument reduction for sin and cos: x = n*(pi/2) + (y0 + y1), |y0 + y1| <~ pi/4.

Ports the "medium" Cody-Waite path of fdlibm's e_rem_pio2.c (FreeBSD msun / openlibm) for |x| < 2^20*(pi/2). Larger
arguments are reduced exactly with Python integers, instead of k_rem_pio2.c: x = m*2^e exactly, multiplied by 1584
bits of 2/pi (the ipio2 table of k_rem_pio2.c), then the fraction times pi/2 rounded to a double-double.

Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
Developed at SunPro, a Sun Microsystems, Inc. business.
Permission to use, copy, modify, and distribute this software is freely granted, provided that this notice is
preserved.
"""

from math import fabs, frexp, ldexp

from numerics._bits import from_words

_INVPIO2 = 6.36619772367581382433e-01  # 0x3FE45F30, 0x6DC9C883: 53 bits of 2/pi
_PIO2_1 = 1.57079632673412561417e00  # 0x3FF921FB, 0x54400000: first 33 bits of pi/2
_PIO2_1T = 6.07710050650619224932e-11  # 0x3DD0B461, 0x1A626331: pi/2 - PIO2_1
_PIO2_2 = 6.07710050630396597660e-11  # 0x3DD0B461, 0x1A600000: second 33 bits of pi/2
_PIO2_2T = 2.02226624879595063154e-21  # 0x3BA3198A, 0x2E037073: pi/2 - (PIO2_1 + PIO2_2)
_PIO2_3 = 2.02226624871116645580e-21  # 0x3BA3198A, 0x2E000000: third 33 bits of pi/2
_PIO2_3T = 8.47842766036889956997e-32  # 0x397B839A, 0x252049C1: pi/2 - (PIO2_1 + PIO2_2 + PIO2_3)
_TO_INT = 6755399441055744.0  # 0x1.8p52: (v + TO_INT) - TO_INT rounds v to an integer (round to nearest)
_TWO_M16 = 1.52587890625e-05  # 2^-16
_TWO_M49 = 1.7763568394002505e-15  # 2^-49
MEDIUM_LIMIT = from_words(0x413921FB, 0)  # ~2^20*(pi/2): the medium path below, the exact one above

# 2/pi in 24-bit chunks after the binary point (k_rem_pio2.c, ipio2[], the 66 entries for double).
_IPIO2 = (
    0xA2F983, 0x6E4E44, 0x1529FC, 0x2757D1, 0xF534DD, 0xC0DB62,
    0x95993C, 0x439041, 0xFE5163, 0xABDEBB, 0xC561B7, 0x246E3A,
    0x424DD2, 0xE00649, 0x2EEA09, 0xD1921C, 0xFE1DEB, 0x1CB129,
    0xA73EE8, 0x8235F5, 0x2EBB44, 0x84E99C, 0x7026B4, 0x5F7E41,
    0x3991D6, 0x398353, 0x39F49C, 0x845F8B, 0xBDF928, 0x3B1FF8,
    0x97FFDE, 0x05980F, 0xEF2F11, 0x8B5A0A, 0x6D1F6D, 0x367ECF,
    0x27CB09, 0xB74F46, 0x3F669E, 0x5FEA2D, 0x7527BA, 0xC7EBE5,
    0xF17B3D, 0x0739F7, 0x8A5292, 0xEA6BFB, 0x5FB11F, 0x8D5D08,
    0x560330, 0x46FC7B, 0x6BABF0, 0xCFBC20, 0x9AF436, 0x1DA9E3,
    0x91615E, 0xE61B08, 0x659985, 0x5F14A0, 0x68408D, 0xFFD880,
    0x4D7327, 0x310606, 0x1556CA, 0x73A8C9, 0x60E27B, 0xC08C6B,
)  # fmt: skip
TWO_OVER_PI_BITS = 24 * len(_IPIO2)  # 1584
TWO_OVER_PI = sum(chunk << (TWO_OVER_PI_BITS - 24 * (i + 1)) for i, chunk in enumerate(_IPIO2))  # floor(2/pi*2^1584)
_PIO2_BITS = 256
PIO2 = (1 << (TWO_OVER_PI_BITS + _PIO2_BITS)) // TWO_OVER_PI  # pi/2 * 2^256, good to ~250 bits


def rem_pio2(x: float) -> tuple[int, float, float]:
    """(n, y0, y1) with x = n*(pi/2) + y0 + y1 for finite x (e_rem_pio2.c, __ieee754_rem_pio2).

    The medium case: 33+33+33+53 bits of pi/2, as many rounds as the cancellation needs. fdlibm compares exponents
    (a 2nd round when y0's is more than 16 below x's, a 3rd at 49); |y0| < |x|*2^-16 (2^-49) asks for a round in
    every case fdlibm does, and in a few more, without reading exponents.
    """
    if not -MEDIUM_LIMIT < x < MEDIUM_LIMIT:
        return rem_pio2_large(x)
    fn = (x * _INVPIO2 + _TO_INT) - _TO_INT
    r = x - fn * _PIO2_1
    w = fn * _PIO2_1T  # 1st round good to 85 bits
    y0 = r - w
    ax = fabs(x)
    if fabs(y0) < ax * _TWO_M16:  # 2nd iteration needed, good to 118 bits
        t = r
        w = fn * _PIO2_2
        r = t - w
        w = fn * _PIO2_2T - ((t - r) - w)
        y0 = r - w
        if fabs(y0) < ax * _TWO_M49:  # 3rd iteration needed, 151 bits
            t = r
            w = fn * _PIO2_3
            r = t - w
            w = fn * _PIO2_3T - ((t - r) - w)
            y0 = r - w
    return int(fn), y0, (r - y0) - w


def rem_pio2_large(x: float) -> tuple[int, float, float]:
    """Exact reduction with integers for any finite x (replaces k_rem_pio2.c); correctly rounded y0, y1."""
    mantissa, exponent = frexp(x)
    m = int(ldexp(mantissa, 53))  # x = m * 2^(exponent - 53) exactly
    shift = TWO_OVER_PI_BITS - (exponent - 53)  # x*2/pi ~ m*TWO_OVER_PI / 2^shift
    product = m * TWO_OVER_PI
    n = product >> shift
    fraction = product - (n << shift)  # in [0, 2^shift)
    if fraction >= 1 << (shift - 1):  # nearest multiple of pi/2: fraction in [-1/2, 1/2)
        n += 1
        fraction -= 1 << shift
    numerator = fraction * PIO2  # y = numerator / 2^(shift + 256)
    scale = shift + _PIO2_BITS
    y0 = numerator / (1 << scale)  # int / int is correctly rounded
    top, bottom = y0.as_integer_ratio()
    y1 = (numerator * bottom - (top << scale)) / (bottom << scale)
    return n, y0, y1

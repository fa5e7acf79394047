"""Deterministic elementary functions: the lowest layer of cpf-cosim (it imports nothing from the project).

Contract: results depend only on IEEE-754 double arithmetic in a fixed order: the same bits on every CPU, OS and libm.
The functions use Python float +, -, *, / and math.sqrt (all correctly rounded in IEEE-754 double, and CPython never
contracts them into an FMA) and exact operations (math.frexp, math.ldexp, math.fabs, math.copysign, comparisons,
int(), the bits through struct). They never call the platform's libm for sin, exp, log and the like, whose results
(glibc picks FMA/AVX2 variants per CPU) can differ in the last bit between machines.

The algorithms and constants are Sun's fdlibm (as in FreeBSD msun and openlibm); each module names the files it
ports. Accuracy: within 1 ULP of the true value (exp10 a few ULP, erfc 2 ULP relative).

sincos, cos, atan2, tanh and numerics.lanes also take numpy arrays of lanes (many vehicles at once: vehicles.lanes),
with numpy's exact or elementwise operations only (tests/test_numerics.py lists them), lane by lane the same bits.

Unlike Python's math module, nothing raises on a domain or range error: the results are those of C, e.g.
log(0) = -inf, log(-1) = nan, asin(2) = nan, sin(inf) = nan, exp(1000) = inf, exp(-1000) = 0.0.

Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
Developed at SunPro, a Sun Microsystems, Inc. business.
Permission to use, copy, modify, and distribute this software is freely granted, provided that this notice is
preserved.
"""

from numerics.erf import erf, erfc
from numerics.exponential import exp, exp10, expm1, tanh
from numerics.logarithm import log, log1p, log10
from numerics.trig import asin, atan, atan2, cos, sin, sincos

__all__ = [
    "asin",
    "atan",
    "atan2",
    "cos",
    "erf",
    "erfc",
    "exp",
    "exp10",
    "expm1",
    "log",
    "log1p",
    "log10",
    "sin",
    "sincos",
    "tanh",
]

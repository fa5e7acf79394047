"""Small matrix products whose bits do not depend on the CPU: sums in a fixed order of elementwise operations.

numpy's `@`, `dot`, `linalg.norm` of a vector, `inv` and `det` call BLAS and LAPACK, and OpenBLAS picks its kernel
per CPU (`DYNAMIC_ARCH`): a Haswell kernel fuses multiply and add (FMA) where a Sandy Bridge one rounds twice, so the
last bits of a product depend on the machine. numpy's elementwise operations (+, -, *, /, sqrt), on the other hand,
are IEEE-754 operations on each element, the same on every CPU whatever SIMD width runs them. So a product here is
built as a sum over k of the outer products a[:, k] b[k, :], accumulated k = 0, 1, ... in that order: the same
rounding as the textbook loop, on any machine. Meant for the small matrices of a vehicle's step (a 6-state Kalman
filter), where numpy's per-call cost, not the arithmetic, is what a product costs.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

Matrix = NDArray[np.float64]


def matmul(a: Matrix, b: Matrix) -> Matrix:
    """a @ b for 2-D a (n x m) and b (m x p), or 1-D b (m,) giving (n,): sum_k a[:, k] b[k], k = 0, 1, ... in order."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.ndim != 2 or b.ndim not in (1, 2) or a.shape[1] != b.shape[0] or a.shape[1] == 0:
        raise ValueError(f"matmul: shapes {a.shape} and {b.shape} do not chain")
    column = a[:, 0:1] if b.ndim == 2 else a[:, 0]
    out: Matrix = column * b[0]
    for k in range(1, a.shape[1]):
        column = a[:, k : k + 1] if b.ndim == 2 else a[:, k]
        out = out + column * b[k]
    return out


def dot(u: Any, v: Any) -> float:
    """sum_i u_i v_i in the order i = 0, 1, ..., in Python floats."""
    total = 0.0
    for x, y in zip(u, v, strict=True):
        total += float(x) * float(y)
    return total


def norm3(x: float, y: float, z: float) -> float:
    """|(x, y, z)| as sqrt((x x + y y) + z z) in Python floats: the same bits as row_norms' row, on every CPU
    (numpy's `linalg.norm` of a vector is BLAS's dot, whose kernel rounds differently per CPU: 11 % of random
    3-vectors differed in their last bit from this on a Xeon with FMA)."""
    return math.sqrt(x * x + y * y + z * z)


def row_norms(vectors: Any) -> Matrix:
    """|row| of an (n, 3) array, elementwise in the order of norm3: the same bits as norm3 of each row."""
    rows = np.asarray(vectors, dtype=np.float64)
    x, y, z = rows[:, 0], rows[:, 1], rows[:, 2]
    out: Matrix = np.sqrt(x * x + y * y + z * z)
    return out


def det(a: Matrix) -> float:
    """The determinant of a 1 x 1, 2 x 2 or 3 x 3 matrix by cofactors (in that order of terms)."""
    m = np.asarray(a, dtype=np.float64).tolist()
    n = len(m)
    if n == 1:
        return float(m[0][0])
    if n == 2:
        return float(m[0][0] * m[1][1] - m[0][1] * m[1][0])
    if n == 3:
        (a11, a12, a13), (a21, a22, a23), (a31, a32, a33) = m
        return float(a11 * (a22 * a33 - a23 * a32) - a12 * (a21 * a33 - a23 * a31) + a13 * (a21 * a32 - a22 * a31))
    raise ValueError(f"det: only 1 x 1 to 3 x 3 matrices, got {n} x {n}")


def inverse(a: Matrix) -> Matrix:
    """The inverse of a 1 x 1, 2 x 2 or 3 x 3 matrix by its adjugate over its determinant; ZeroDivisionError for a
    singular one."""
    m = np.asarray(a, dtype=np.float64).tolist()
    d = det(np.asarray(a, dtype=np.float64))
    if d == 0.0:
        raise ZeroDivisionError("inverse: singular matrix")
    if len(m) == 1:
        return np.array([[1.0 / d]])
    if len(m) == 2:
        (p, q), (r, s) = m
        return np.array([[s / d, -q / d], [-r / d, p / d]])
    (a11, a12, a13), (a21, a22, a23), (a31, a32, a33) = m
    adj = [
        [a22 * a33 - a23 * a32, a13 * a32 - a12 * a33, a12 * a23 - a13 * a22],
        [a23 * a31 - a21 * a33, a11 * a33 - a13 * a31, a13 * a21 - a11 * a23],
        [a21 * a32 - a22 * a31, a12 * a31 - a11 * a32, a11 * a22 - a12 * a21],
    ]
    return np.array([[x / d for x in row] for row in adj])

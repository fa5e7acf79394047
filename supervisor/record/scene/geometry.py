"""Geometry for the Foxglove scene: attitude quaternions from the recorded rotation matrices, a path as a polyline.

The log keeps a vehicle's attitude as R (body to inertial, row-major, re-projected onto SO(3) every step); Foxglove
wants a unit quaternion (x, y, z, w). The conversion is Shepperd's: of the four ways to read the quaternion off R
it takes the one whose pivot (4 q_i^2, from the trace or a diagonal element) is largest, so it never divides by a
small number, whatever the rotation (180 degrees included); a matrix slightly off SO(3) still gives its nearest
reading, normalised. S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance and Control 1(3), 1978;
F. L. Markley, "Unit quaternion from rotation matrix", J. Guidance, Control, and Dynamics 31(2), 2008.
Hand-written (tests check it against scipy's Rotation) because scipy.spatial takes a quarter of a second to import
in the supervisor, for 15 lines of arithmetic.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from vehicles.paths import Path

FloatArray = NDArray[np.float64]
COARSE = 257  # samples to measure a path's length before sampling it
_NEXT = ((1, 2), (2, 0), (0, 1))  # (j, k) after i, cyclic


def quaternions(rotations: FloatArray) -> FloatArray:
    """Unit quaternions (x, y, z, w), w >= 0, of rotation matrices: shape (n, 9) row-major or (n, 3, 3) -> (n, 4)."""
    r = np.asarray(rotations, dtype=np.float64).reshape(-1, 3, 3)
    diagonal = np.diagonal(r, axis1=1, axis2=2)
    trace = diagonal.sum(axis=1)
    pivot = np.argmax(np.column_stack([diagonal, trace]), axis=1)
    q = np.empty((len(r), 4))
    w_largest = pivot == 3
    q[w_largest] = _from_trace(r[w_largest], trace[w_largest])
    for i, (j, k) in enumerate(_NEXT):
        rows = pivot == i
        m = r[rows]
        q[rows, i] = 1.0 + 2.0 * m[:, i, i] - trace[rows]
        q[rows, j] = m[:, j, i] + m[:, i, j]
        q[rows, k] = m[:, k, i] + m[:, i, k]
        q[rows, 3] = m[:, k, j] - m[:, j, k]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[q[:, 3] < 0] *= -1.0  # q and -q are the same attitude: one of them, always the same
    return q


def _from_trace(r: FloatArray, trace: FloatArray) -> FloatArray:
    """4 w q, read where w is the largest component: (R21 - R12, R02 - R20, R10 - R01, 1 + trace)."""
    return np.column_stack([r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1], 1.0 + trace])


def path_points(path: Path, low: float, high: float, spacing: float, most: int) -> FloatArray:
    """p_d(gamma) for gamma from low to high, evenly in gamma, about `spacing` m apart along the path (at least 2
    points, at most `most`): shape (n, 3)."""
    coarse = path.positions(np.linspace(low, high, COARSE))
    length = float(np.linalg.norm(np.diff(coarse, axis=0), axis=1).sum())
    count = min(max(2, math.ceil(length / spacing) + 1), most) if math.isfinite(length) else 2
    return path.positions(np.linspace(low, high, count))

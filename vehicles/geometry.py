"""Small rotation and vector helpers shared by the dynamics and the controllers.

Frames: the inertial frame {I} has z pointing up (the paper's helix climbs with gamma); the body frame {B} has x
forward, y to port, z up when R = I. R maps body coordinates into inertial ones (paper, eq. 1).

Everything a run computes goes through float arithmetic and numerics' trigonometry, never LAPACK or numpy's `@`
(their kernels differ between CPUs): `orthonormalize`, the SVD, is the reference the tests hold the float versions to.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from comms.records.records import FloatArray
from numerics import asin, atan2, sincos

Float3 = tuple[float, float, float]  # a 3-vector as plain floats, for the hot path


def orthonormalize(rotation: FloatArray) -> FloatArray:
    """The rotation nearest to a drifted one (polar factor), so integration error never leaves SO(n)."""
    u, _, vt = np.linalg.svd(rotation)
    nearest: FloatArray = u @ vt
    if np.linalg.det(nearest) < 0.0:  # a reflection can only come from a corrupt input; flip back into SO(n)
        u[:, -1] = -u[:, -1]
        nearest = u @ vt
    return nearest


# How far R'R may be from I for the Newton-Schulz projection; beyond it (never after an RK4 step) the SVD takes over.
_NEWTON_SCHULZ_RANGE = 1e-3
# Below this |R'R - I|, one more iteration leaves an error of 0.75 |R'R - I|^2 < 1e-16: round-off.
_ONE_ITERATION_LEFT = 1e-8


def reorthonormalized(r: Sequence[float]) -> tuple[float, ...]:
    """orthonormalize for a row-major 3x3 matrix that integration has moved slightly off SO(3), in floats.

    Newton-Schulz, X <- X - X (X'X - I) / 2, converges quadratically to the same polar factor as the SVD while
    X'X - I is small: one iteration takes RK4's drift below round-off, without numpy's per-call cost. A matrix far
    from a rotation goes to Newton's polar iteration (_polar), in floats too; only a reflection, which no RK4 step of
    a rotation gives, goes to orthonormalize (LAPACK) and its guard."""
    m = tuple(r)
    for _ in range(4):
        a, b, c, d, e, f, g, h, i = m
        # E / 2 with E = X'X - I, from the columns (a, d, g), (b, e, h), (c, f, i); symmetric.
        e11, e22, e33 = a * a + d * d + g * g - 1.0, b * b + e * e + h * h - 1.0, c * c + f * f + i * i - 1.0
        e12, e13, e23 = a * b + d * e + g * h, a * c + d * f + g * i, b * c + e * f + h * i
        drift = max(abs(e11), abs(e22), abs(e33), abs(e12), abs(e13), abs(e23))
        if drift > _NEWTON_SCHULZ_RANGE or a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) <= 0.0:
            break
        e11, e22, e33, e12, e13, e23 = 0.5 * e11, 0.5 * e22, 0.5 * e33, 0.5 * e12, 0.5 * e13, 0.5 * e23
        m = (
            a - (a * e11 + b * e12 + c * e13), b - (a * e12 + b * e22 + c * e23), c - (a * e13 + b * e23 + c * e33),
            d - (d * e11 + e * e12 + f * e13), e - (d * e12 + e * e22 + f * e23), f - (d * e13 + e * e23 + f * e33),
            g - (g * e11 + h * e12 + i * e13), h - (g * e12 + h * e22 + i * e23), i - (g * e13 + h * e23 + i * e33),
        )  # fmt: skip
        if drift < _ONE_ITERATION_LEFT:
            return m
    a, b, c, d, e, f, g, h, i = r
    if a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) <= 0.0:  # a reflection: corrupt input only
        return tuple(orthonormalize(np.array(r, dtype=float).reshape(3, 3)).reshape(9).tolist())
    return _polar(tuple(r))


def _polar(m: tuple[float, ...]) -> tuple[float, ...]:
    """The polar factor of a row-major 3x3 matrix with a positive determinant, by Newton's iteration
    X <- (X + X^-T) / 2 (Higham, Functions of Matrices, SIAM 2008, sec. 8.3): quadratic convergence from any such
    matrix, in floats, where Newton-Schulz's range ends; the same factor as the SVD's u v'."""
    for _ in range(64):
        a, b, c, d, e, f, g, h, i = m
        co = (e * i - f * h, f * g - d * i, d * h - e * g, c * h - b * i, a * i - c * g, b * g - a * h,
              b * f - c * e, c * d - a * f, a * e - b * d)  # fmt: skip
        det = a * co[0] + b * co[1] + c * co[2]
        nxt = tuple(0.5 * (x + y / det) for x, y in zip(m, co, strict=True))
        change = max(abs(x - y) for x, y in zip(nxt, m, strict=True))
        m = nxt
        if change <= 1e-15:
            break
    return m


def rotation_from_rpy(roll: float, pitch: float, yaw: float) -> FloatArray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), angles in radians. Only used to set up initial attitudes."""
    sr, cr = sincos(roll)
    sp, cp = sincos(pitch)
    sy, cy = sincos(yaw)
    return np.array([
        [cy * cp, cy * (sp * sr) - sy * cr, cy * (sp * cr) + sy * sr],
        [sy * cp, sy * (sp * sr) + cy * cr, sy * (sp * cr) - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])  # fmt: skip


def rotation_2d(yaw: float) -> FloatArray:
    """Planar rotation by yaw (rad)."""
    s, c = sincos(yaw)
    return np.array([[c, -s], [s, c]])


def roll_pitch_yaw(rotation: FloatArray) -> tuple[float, float, float]:
    """Inverse of rotation_from_rpy, for telemetry and plots (not used in control: the state keeps R)."""
    pitch = -asin(max(-1.0, min(1.0, float(rotation[2, 0]))))
    roll = atan2(float(rotation[2, 1]), float(rotation[2, 2]))
    yaw = atan2(float(rotation[1, 0]), float(rotation[0, 0]))
    return roll, pitch, yaw

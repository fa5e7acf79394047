"""Small rotation and vector helpers shared by the dynamics and the controllers.

Frames: the inertial frame {I} has z pointing up (the paper's helix climbs with gamma); the body frame {B} has x
forward, y to port, z up when R = I. R maps body coordinates into inertial ones (paper, eq. 1).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def skew(x: FloatArray) -> FloatArray:
    """S(x) of the paper: S(x) y = x cross y, for x in R^3."""
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


def skew2(r: float) -> FloatArray:
    """The planar S(omega) = [[0, -r], [r, 0]]."""
    return np.array([[0.0, -r], [r, 0.0]])


def orthonormalize(rotation: FloatArray) -> FloatArray:
    """The rotation nearest to a drifted one (polar factor), so integration error never leaves SO(n)."""
    u, _, vt = np.linalg.svd(rotation)
    nearest: FloatArray = u @ vt
    if np.linalg.det(nearest) < 0.0:  # a reflection can only come from a corrupt input; flip back into SO(n)
        u[:, -1] = -u[:, -1]
        nearest = u @ vt
    return nearest


def rotation_from_rpy(roll: float, pitch: float, yaw: float) -> FloatArray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), angles in radians. Only used to set up initial attitudes."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    result: FloatArray = rz @ ry @ rx
    return result


def rotation_2d(yaw: float) -> FloatArray:
    """Planar rotation by yaw (rad)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


def roll_pitch_yaw(rotation: FloatArray) -> tuple[float, float, float]:
    """Inverse of rotation_from_rpy, for telemetry and plots (not used in control: the state keeps R)."""
    pitch = -math.asin(max(-1.0, min(1.0, float(rotation[2, 0]))))
    roll = math.atan2(float(rotation[2, 1]), float(rotation[2, 2]))
    yaw = math.atan2(float(rotation[1, 0]), float(rotation[0, 0]))
    return roll, pitch, yaw

"""Acoustic propagation: time of flight between moving vehicles and packet airtime.

Sources: shared/reference/acoustics.md. Sound speed about 1500 m/s; the time of flight solves
|p_rx(t_tx + tau) - p_tx(t_tx)| = c tau: the sender's position at transmission, the receiver's at arrival.
"""

from __future__ import annotations

import math

from vehicles.geometry import FloatArray


def time_of_flight(
    sender: FloatArray, receiver: FloatArray, receiver_velocity: FloatArray, sound_speed: float
) -> float:
    """tau > 0 with |receiver + v tau - sender| = c tau, the receiver moving at constant velocity v (|v| < c).

    With d = receiver - sender this is (c^2 - |v|^2) tau^2 - 2 (d.v) tau - |d|^2 = 0; the positive root.
    """
    dx = [float(receiver[i] - sender[i]) for i in range(3)]
    v = [float(receiver_velocity[i]) for i in range(3)]
    dd = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]
    dv = dx[0] * v[0] + dx[1] * v[1] + dx[2] * v[2]
    a = sound_speed * sound_speed - (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return max(0.0, (dv + math.sqrt(dv * dv + a * dd)) / a)  # max: rounding at vanishing distances


def airtime(size_bytes: int, bitrate: float | None) -> float:
    """Seconds a packet of size_bytes occupies the channel at bitrate bit/s (0 when the bitrate is unlimited)."""
    return 0.0 if bitrate is None else 8.0 * size_bytes / bitrate

"""Acoustic propagation: time of flight, airtime, sound speed, absorption, noise and the link budget.

Sources: shared/reference/acoustics.md.
- Time of flight: sound speed about 1500 m/s; tau solves |p_rx(t_tx + tau) - p_tx(t_tx)| = c tau (the sender's
  position at transmission, the receiver's at arrival).
- Sound speed: Mackenzie, "Nine-term equation for sound speed in the oceans", JASA 70(3), 1981 (m/s; T in deg C,
  S in ppt, D in m; valid T 2-30, S 25-40, D 0-8000; check value 1550.744 m/s at 25 C, 35 ppt, 1000 m).
- Absorption: Thorp's formula in the dB/km form (f in kHz) used by Stojanovic, "On the relationship between capacity
  and distance in an underwater acoustic communication channel", WUWNet 2006.
- Transmission loss (dB re 1 m): k 10 log10(l) + l alpha, l in m, practical spreading k = 1.5.
- Ambient noise (dB re 1 uPa^2/Hz, f in kHz): Coates, "Underwater Acoustic Systems", 1989, via Stojanovic 2006:
  turbulence, shipping (activity s in [0, 1]), wind (w in m/s) and thermal noise, summed in power.
- SNR (dB) = SL - TL - NL - 10 log10(B) + DI; bit error: coherent BPSK 0.5 erfc(sqrt(ebn0)), non-coherent binary
  FSK 0.5 exp(-ebn0 / 2) (Proakis, Digital Communications), with Eb/N0 = SNR B / R (the energy of one bit over the
  noise in one hertz: SNR in the band B, R bits per second); packet error 1 - (1 - Pb)^bits.

Transcendental functions come from numerics, powers are products: the C library's pow, log10, erfc, ... pick
CPU-specific kernels, and these numbers decide packets' fates and delays.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from comms.records.records import FloatArray
from numerics import erfc, exp, exp10, expm1, log1p, log10

Vector = FloatArray | Sequence[float]  # three components, in an array or in floats


def time_of_flight(sender: Vector, receiver: Vector, receiver_velocity: Vector, sound_speed: float) -> float:
    """tau > 0 with |receiver + v tau - sender| = c tau, the receiver moving at constant velocity v (|v| < c).

    With d = receiver - sender this is (c^2 - |v|^2) tau^2 - 2 (d.v) tau - |d|^2 = 0; the positive root.
    """
    return flight_time(floats(sender), floats(receiver), floats(receiver_velocity), sound_speed)


def flight_time(tx: Sequence[float], rx: Sequence[float], v: Sequence[float], sound_speed: float) -> float:
    """time_of_flight of vectors already in floats (the channel converts a sender's position once per packet)."""
    # In floats (numpy's per-element indexing cost more than the arithmetic); the same float64 subtractions.
    dx0, dx1, dx2 = rx[0] - tx[0], rx[1] - tx[1], rx[2] - tx[2]
    v0, v1, v2 = v[0], v[1], v[2]
    dd = dx0 * dx0 + dx1 * dx1 + dx2 * dx2
    dv = dx0 * v0 + dx1 * v1 + dx2 * v2
    a = sound_speed * sound_speed - (v0 * v0 + v1 * v1 + v2 * v2)
    root = (dv + math.sqrt(dv * dv + a * dd)) / a
    return root if root > 0.0 else 0.0  # not max(): rounding at vanishing distances, without a call


def floats(vector: Vector) -> list[float]:
    """A vector's components as Python floats (their values unchanged)."""
    values: list[float] = vector.tolist() if isinstance(vector, np.ndarray) else [float(c) for c in vector]
    return values


def airtime(size_bytes: int, bitrate: float | None) -> float:
    """Seconds a packet of size_bytes occupies the channel at bitrate bit/s (0 when the bitrate is unlimited)."""
    return 0.0 if bitrate is None else 8.0 * size_bytes / bitrate


Modulation = Literal["bpsk", "fsk"]
MODULATIONS: tuple[Modulation, ...] = ("bpsk", "fsk")


def _require(ok: bool, name: str, value: object, what: str) -> None:
    if not ok:
        raise ValueError(f"{name} must be {what}, got {value!r}")


def mackenzie_sound_speed(temperature_c: float, salinity_ppt: float, depth_m: float) -> float:
    """Sound speed in m/s by Mackenzie's nine-term formula (1981); T in deg C, S in ppt, D in m."""
    t, ds, d = temperature_c, salinity_ppt - 35.0, depth_m
    return (
        1448.96
        + 4.591 * t
        - 5.304e-2 * (t * t)
        + 2.374e-4 * (t * t * t)
        + 1.340 * ds
        + 1.630e-2 * d
        + 1.675e-7 * (d * d)
        - 1.025e-2 * t * ds
        - 7.139e-13 * t * (d * d * d)
    )


def thorp_absorption_db_per_km(f_khz: float) -> float:
    """Thorp's absorption coefficient in dB/km, f in kHz (the dB/km form, not the original dB/kyd one)."""
    _require(f_khz > 0.0, "f_khz", f_khz, "> 0")
    f2 = f_khz * f_khz
    return 0.11 * f2 / (1.0 + f2) + 44.0 * f2 / (4100.0 + f2) + 2.75e-4 * f2 + 0.003


def transmission_loss_db(distance_m: float, f_khz: float, spreading: float = 1.5) -> float:
    """TL = k 10 log10(l) + l alpha in dB, l in m, alpha in dB/m.

    Below 1 m, l is taken as 1 m: the source level is referenced at 1 m, so the loss there is zero.
    """
    _require(distance_m >= 0.0, "distance_m", distance_m, ">= 0")
    length = max(distance_m, 1.0)
    return spreading * 10.0 * log10(length) + length * thorp_absorption_db_per_km(f_khz) / 1000.0


def _power_sum_db(levels_db: list[float]) -> float:
    """10 log10 of the sum of the powers: uncorrelated noise sources add in power, not in dB."""
    return 10.0 * log10(sum(exp10(x / 10.0) for x in levels_db))


def noise_psd_db(f_khz: float, shipping: float = 0.5, wind_m_s: float = 0.0) -> float:
    """Ambient noise power spectral density in dB re 1 uPa^2/Hz (Coates), f in kHz.

    shipping is the shipping activity in [0, 1], wind_m_s the wind speed in m/s.
    """
    _require(f_khz > 0.0, "f_khz", f_khz, "> 0")
    _require(0.0 <= shipping <= 1.0, "shipping", shipping, "in [0, 1]")
    _require(wind_m_s >= 0.0, "wind_m_s", wind_m_s, ">= 0")
    lf = log10(f_khz)
    turbulence = 17.0 - 30.0 * lf
    ships = 40.0 + 20.0 * (shipping - 0.5) + 26.0 * lf - 60.0 * log10(f_khz + 0.03)
    wind = 50.0 + 7.5 * math.sqrt(wind_m_s) + 20.0 * lf - 40.0 * log10(f_khz + 0.4)
    thermal = -15.0 + 20.0 * lf
    return _power_sum_db([turbulence, ships, wind, thermal])


def snr_db(
    source_level_db: float,
    distance_m: float,
    f_khz: float,
    bandwidth_hz: float,
    spreading: float = 1.5,
    shipping: float = 0.5,
    wind_m_s: float = 0.0,
    directivity_db: float = 0.0,
) -> float:
    """In-band SNR in dB: SL - TL - NL - 10 log10(B) + DI (SL in dB re 1 uPa at 1 m, B in Hz).

    The noise PSD is taken at the carrier f_khz, flat over the band.
    """
    _require(bandwidth_hz > 0.0, "bandwidth_hz", bandwidth_hz, "> 0")
    loss = transmission_loss_db(distance_m, f_khz, spreading)
    noise = noise_psd_db(f_khz, shipping, wind_m_s) + 10.0 * log10(bandwidth_hz)
    return source_level_db - loss - noise + directivity_db


def ebn0_db(snr_db: float, bandwidth_hz: float, bitrate: float) -> float:
    """Eb/N0 in dB from the in-band SNR: Eb/N0 = SNR B / R (+17 dB for 80 bit/s in 4 kHz)."""
    _require(bandwidth_hz > 0.0, "bandwidth_hz", bandwidth_hz, "> 0")
    _require(bitrate > 0.0, "bitrate", bitrate, "> 0")
    return snr_db + 10.0 * log10(bandwidth_hz / bitrate)


def bit_error_rate(snr_db: float, modulation: Modulation) -> float:
    """Bit error probability at Eb/N0 = snr_db (dB) for coherent BPSK or non-coherent binary FSK."""
    snr = exp10(snr_db / 10.0)
    if modulation == "bpsk":
        return 0.5 * erfc(math.sqrt(snr))  # erfc keeps relative precision in the tail
    if modulation == "fsk":
        return 0.5 * exp(-snr / 2.0)
    raise ValueError(f"modulation must be one of {MODULATIONS}, got {modulation!r}")


def packet_error_rate(ber: float, bits: int) -> float:
    """1 - (1 - ber)^bits, as -expm1(bits log1p(-ber)) so that tiny ber and large bits keep their precision."""
    _require(0.0 <= ber <= 1.0, "ber", ber, "in [0, 1]")
    _require(bits >= 0, "bits", bits, ">= 0")
    if ber == 1.0:
        return 1.0 if bits > 0 else 0.0  # log1p(-1) is -inf
    return -expm1(bits * log1p(-ber))

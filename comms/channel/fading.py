"""Shadowing and fast fading on the acoustic link budget, and the mean packet error they give.

- Log-normal shadowing: a Gaussian term X ~ N(0, sigma^2) in dB on the SNR, correlated over time on one link as a
  first-order Gauss-Markov process with correlation time T: X' = rho X + sqrt(1 - rho^2) sigma Z, rho = exp(-dt / T)
  (Gudmundson, "Correlation model for shadow fading in mobile radio systems", Electronics Letters 27(23), 1991);
  T = 0 draws a fresh X for every packet.
- Fast fading: the received power gain g = |h|^2, h = sqrt(K / (K + 1)) + sqrt(1 / (K + 1)) CN(0, 1): Rician with
  K factor K (line-of-sight over scattered power), Rayleigh for K = 0 (Proakis, Digital Communications, ch. 13;
  UnetStack's BasicAcousticChannel uses Rician fading the same way). E[g] = 1: the mean received power is the link
  budget's. One independent draw per packet: the acoustic channel's coherence time (well under a second) is far
  below the time between two packets on a link.
scipy is imported only where the mean is integrated: a vehicle process, which imports the channel, stays light.
Normals come from uniforms by Box-Muller, a fixed number of uniforms per packet, so random streams stay aligned.
The mean packet error over shadowing and fading is integrated numerically: the distribution of the total gain in dB
(shadowing convolved with the fading gain, exact cell masses on a fine dB grid) weighs the packet error there.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache

import numpy as np

from comms.records.records import FloatArray
from numerics import exp, log1p, log10, sincos

GRID_DB = 0.01  # dB between the points the mean packet error is summed over
FADE_FLOOR_DB = -120.0  # deeper fades (probability ~1e-12 for Rayleigh) are lumped here: the packet is lost anyway
FADE_CEILING_DB = 20.0  # a Rician power gain above 100 has probability below e^-90 for any K


def box_muller(u1: float, u2: float) -> tuple[float, float]:
    """Two independent standard normals from two uniforms in [0, 1) (1 - u1 is in (0, 1]: the log is finite)."""
    radius = math.sqrt(-2.0 * log1p(-u1))
    angle = 2.0 * math.pi * u2
    sine, cosine = sincos(angle)
    return radius * cosine, radius * sine


def rician_gain_db(u1: float, u2: float, k_factor: float) -> float:
    """The fast-fading power gain in dB from two uniforms: Rician with K = k_factor, Rayleigh for K = 0."""
    z1, z2 = box_muller(u1, u2)
    scatter = math.sqrt(0.5 / (k_factor + 1.0))  # each quadrature of CN(0, 1 / (K + 1))
    los = math.sqrt(k_factor / (k_factor + 1.0))
    in_phase, quadrature = los + scatter * z1, scatter * z2
    power = in_phase * in_phase + quadrature * quadrature
    return 10.0 * log10(power) if power > 0.0 else FADE_FLOOR_DB


def shadowing_step(previous_db: float | None, z: float, sigma_db: float, elapsed: float, correlation: float) -> float:
    """The link's shadowing now, from its value at its last packet (None: the first packet, drawn stationary),
    a standard normal z, the time elapsed since (s) and the correlation time (s; 0: independent per packet)."""
    if previous_db is None or correlation <= 0.0:
        return sigma_db * z
    rho = exp(-max(elapsed, 0.0) / correlation)
    return rho * previous_db + math.sqrt(1.0 - rho * rho) * sigma_db * z


def _cell_masses(cdf: Callable[[FloatArray], FloatArray], grid: FloatArray) -> FloatArray:
    """Probability of each grid cell [x - h/2, x + h/2), the tails lumped into the end cells."""
    edges = np.concatenate(([-np.inf], (grid[:-1] + grid[1:]) / 2.0, [np.inf]))
    return np.diff(cdf(edges))


def _fading_cdf_db(k_factor: float) -> Callable[[FloatArray], FloatArray]:
    """P(10 log10 g <= y): 2 (K + 1) g is noncentral chi-square with 2 degrees of freedom and non-centrality 2K."""

    def cdf(y_db: FloatArray) -> FloatArray:
        from scipy import stats

        g = np.power(10.0, np.asarray(y_db) / 10.0)
        if k_factor == 0.0:
            return np.asarray(-np.expm1(-g))  # Rayleigh: g ~ Exp(1)
        return np.asarray(stats.ncx2.cdf(2.0 * (k_factor + 1.0) * g, 2, 2.0 * k_factor))

    return cdf


@lru_cache(maxsize=32)
def gain_distribution(sigma_db: float, k_factor: float | None) -> tuple[FloatArray, FloatArray]:
    """(offsets in dB, probabilities) of the total gain shadowing + fading, on a GRID_DB grid."""
    from scipy import signal, stats

    parts: list[FloatArray] = []
    start = 0.0
    if sigma_db > 0.0:
        half = math.ceil(9.0 * sigma_db / GRID_DB)
        grid = GRID_DB * np.arange(-half, half + 1, dtype=float)
        parts.append(_cell_masses(lambda x: np.asarray(stats.norm.cdf(x, scale=sigma_db)), grid))
        start += float(grid[0])
    if k_factor is not None:
        low, high = round(FADE_FLOOR_DB / GRID_DB), round(FADE_CEILING_DB / GRID_DB)
        grid = GRID_DB * np.arange(low, high + 1, dtype=float)
        parts.append(_cell_masses(_fading_cdf_db(k_factor), grid))
        start += float(grid[0])
    masses: FloatArray = np.ones(1)
    for part in parts:
        masses = np.clip(signal.fftconvolve(masses, part), 0.0, None)  # fft rounding can leave -1e-17
    masses = masses / masses.sum()
    return start + GRID_DB * np.arange(len(masses), dtype=float), masses


def mean_over_gain(success: Callable[[FloatArray], FloatArray], sigma_db: float, k_factor: float | None) -> float:
    """E[success(G)] over the total gain G in dB (success: a vectorised function of the gain in dB)."""
    offsets, masses = gain_distribution(sigma_db, k_factor)
    keep = masses > 1e-15  # most of a wide grid carries no weight: skip it
    return float(np.dot(masses[keep], success(offsets[keep])))

"""Range-dependent loss from the acoustic link budget, with optional shadowing and fast fading (comms.channel.fading).

A packet of n bytes is lost with probability PER = 1 - (1 - Pb)^bits, Pb the bit error at the link's Eb/N0:
- bits: every bit sent, the packet padded to whole frames when the modem sends fixed-size frames (frame_bytes);
- Eb/N0 = SNR B / R with the modem's bitrate R (bitrate None: Eb/N0 taken as the in-band SNR, as before issue 16);
- SNR = SL - TL - NL - 10 log10(B) + DI (comms.channel.acoustics) plus, when enabled, the link's shadowing X in dB and
the
  packet's fading gain in dB.
Without shadowing and fading the model is stateless and draws one uniform per packet; with them its links keep their
shadowing state and draw 1 + 2 (shadowing) + 2 (fading) uniforms per packet, whatever the outcome.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from comms.channel.acoustics import (
    MODULATIONS,
    Modulation,
    bit_error_rate,
    ebn0_db,
    noise_psd_db,
    packet_error_rate,
    snr_db,
    transmission_loss_db,
)
from comms.channel.fading import box_muller, mean_over_gain, rician_gain_db, shadowing_step
from comms.records.records import FloatArray
from numerics import log10


def _check(ok: bool, name: str, value: object, what: str) -> None:
    if not ok:
        raise ValueError(f"{name} must be {what}, got {value!r}")


@dataclass(frozen=True, slots=True)
class LinkBudgetRange:
    """Loss from the acoustic link budget at the link's distance.

    Units as in comms.channel.acoustics.snr_db: source level dB re 1 uPa at 1 m, kHz, Hz, wind m/s, directivity dB;
    bitrate bit/s, frame_bytes B, shadowing_db the shadowing's standard deviation in dB, shadowing_time its
    correlation time in s (0: independent per packet), rician_k the fading's K factor (None: no fast fading,
    0: Rayleigh).
    """

    source_level_db: float
    frequency_khz: float
    bandwidth_hz: float
    modulation: Modulation
    spreading: float = 1.5
    shipping: float = 0.5
    wind_m_s: float = 0.0
    directivity_db: float = 0.0
    bitrate: float | None = None
    frame_bytes: int | None = None
    shadowing_db: float = 0.0
    shadowing_time: float = 0.0
    rician_k: float | None = None

    def __post_init__(self) -> None:
        _check(math.isfinite(self.source_level_db), "source_level_db", self.source_level_db, "finite")
        _check(0.0 < self.frequency_khz < math.inf, "frequency_khz", self.frequency_khz, "> 0 and finite")
        _check(0.0 < self.bandwidth_hz < math.inf, "bandwidth_hz", self.bandwidth_hz, "> 0 and finite")
        _check(self.modulation in MODULATIONS, "modulation", self.modulation, f"one of {MODULATIONS}")
        # 1: cylindrical, 2: spherical spreading; anything else is not a physical spreading law.
        _check(1.0 <= self.spreading <= 2.0, "spreading", self.spreading, "in [1, 2]")
        _check(0.0 <= self.shipping <= 1.0, "shipping", self.shipping, "in [0, 1]")
        _check(0.0 <= self.wind_m_s < math.inf, "wind_m_s", self.wind_m_s, ">= 0 and finite")
        _check(math.isfinite(self.directivity_db), "directivity_db", self.directivity_db, "finite")
        _check(self.bitrate is None or 0.0 < self.bitrate < math.inf, "bitrate", self.bitrate, "> 0 and finite")
        _check(self.frame_bytes is None or self.frame_bytes > 0, "frame_bytes", self.frame_bytes, "> 0")
        _check(0.0 <= self.shadowing_db < math.inf, "shadowing_db", self.shadowing_db, ">= 0 and finite")
        _check(0.0 <= self.shadowing_time < math.inf, "shadowing_time", self.shadowing_time, ">= 0 and finite")
        k = self.rician_k
        _check(k is None or 0.0 <= k < math.inf, "rician_k", k, ">= 0 and finite (0: Rayleigh)")

    @property
    def fading(self) -> bool:
        return self.shadowing_db > 0.0 or self.rician_k is not None

    def bits(self, size_bytes: int) -> int:
        """Bits on air: the packet padded to whole frames when the modem sends fixed-size frames."""
        frames = self.frame_bytes
        return 8 * (size_bytes if frames is None else frames * max(1, math.ceil(size_bytes / frames)))

    def mean_snr_db(self, distance_m: float) -> float:
        """In-band SNR in dB without shadowing and fading."""
        return snr_db(
            self.source_level_db, distance_m, self.frequency_khz, self.bandwidth_hz, self.spreading,
            self.shipping, self.wind_m_s, self.directivity_db,
        )  # fmt: skip

    def received_level_db(self, distance_m: float) -> float:
        """Mean received level in dB re 1 uPa: SL - TL + DI."""
        return (
            self.source_level_db
            - transmission_loss_db(distance_m, self.frequency_khz, self.spreading)
            + (self.directivity_db)
        )

    def noise_level_db(self) -> float:
        """In-band noise level in dB re 1 uPa: NL + 10 log10(B)."""
        return noise_psd_db(self.frequency_khz, self.shipping, self.wind_m_s) + 10.0 * log10(self.bandwidth_hz)

    def _ebn0_db(self, snr: float) -> float:
        return snr if self.bitrate is None else ebn0_db(snr, self.bandwidth_hz, self.bitrate)

    def success_probability(self, distance_m: float, size_bytes: int, gain_db: float = 0.0) -> float:
        """1 - PER for a packet of size_bytes over distance_m, the SNR raised by gain_db (shadowing, fading)."""
        ebn0 = self._ebn0_db(self.mean_snr_db(distance_m) + gain_db)
        return 1.0 - packet_error_rate(bit_error_rate(ebn0, self.modulation), self.bits(size_bytes))

    def success_at(self, distance_m: float, size_bytes: int, gains_db: FloatArray) -> FloatArray:
        """success_probability at many gains at once (vectorised, for the mean over shadowing and fading)."""
        from scipy import special  # here: the channel of a vehicle process never integrates

        ebn0 = np.power(10.0, (self._ebn0_db(self.mean_snr_db(distance_m)) + np.asarray(gains_db)) / 10.0)
        ber = 0.5 * special.erfc(np.sqrt(ebn0)) if self.modulation == "bpsk" else 0.5 * np.exp(-ebn0 / 2.0)
        return np.asarray(np.exp(self.bits(size_bytes) * np.log1p(-np.minimum(ber, 1.0 - 1e-16))))

    def mean_success(self, distance_m: float, size_bytes: int) -> float:
        """The expected 1 - PER over shadowing and fading (numerically integrated); without them, the closed form."""
        if not self.fading:
            return self.success_probability(distance_m, size_bytes)
        return mean_over_gain(
            lambda gains: self.success_at(distance_m, size_bytes, gains), self.shadowing_db, self.rician_k
        )

    @property
    def draws(self) -> int:
        return 1 + (2 if self.shadowing_db > 0.0 else 0) + (2 if self.rician_k is not None else 0)

    def link(self) -> LinkBudgetRange | FadingLink:
        return FadingLink(self) if self.fading else self

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        u = rng.random()  # drawn first: consumed whatever the outcome
        return "range" if u >= self.success_probability(distance_m, size_bytes) else None


@dataclass(slots=True)
class FadingLink:
    """One directed link's shadowing (its value and time at the last packet) under a fading link budget."""

    model: LinkBudgetRange
    shadow_db: float | None = field(default=None)
    last_t: float = 0.0

    @property
    def draws(self) -> int:
        return self.model.draws

    def gain_db(self, rng: np.random.Generator, t: float) -> float:
        """This packet's shadowing plus fading in dB; advances the shadowing state."""
        m, gain = self.model, 0.0
        if m.shadowing_db > 0.0:
            u = rng.random(2)
            z, _ = box_muller(float(u[0]), float(u[1]))
            self.shadow_db = shadowing_step(self.shadow_db, z, m.shadowing_db, t - self.last_t, m.shadowing_time)
            self.last_t = t
            gain += self.shadow_db
        if m.rician_k is not None:
            u = rng.random(2)
            gain += rician_gain_db(float(u[0]), float(u[1]), m.rician_k)
        return gain

    def decide(self, rng: np.random.Generator, distance_m: float, size_bytes: int, t: float = 0.0) -> str | None:
        u = rng.random()
        gain = self.gain_db(rng, t)
        return "range" if u >= self.model.success_probability(distance_m, size_bytes, gain) else None

"""Acoustic modems: how long a packet occupies the water, and what the modem can and cannot hear.

A packet is padded to whole frames when the modem sends fixed-size frames; its airtime is the preamble plus its bits
over the bitrate. A half-duplex modem hears nothing while it transmits; with collisions on, two packets that overlap
at a receiver are both lost. Presets from shared/reference/acoustics.md (numbers not given there are left at 0 and
said so).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

Modulation = Literal["fsk", "bpsk"]


@dataclass(frozen=True, slots=True)
class ModemParams:
    bitrate: float | None = None  # bit/s; None: packets take no airtime (the ideal channel)
    preamble: float = 0.0  # s before the data of every packet
    frame_bytes: int | None = None  # fixed frame size: packets are padded to whole frames
    max_bytes: int | None = None  # the largest packet the modem takes
    half_duplex: bool = False  # cannot receive while transmitting
    collisions: bool = False  # overlapping packets at a receiver are lost
    modulation: Modulation = "bpsk"
    frequency_khz: float = 25.0  # carrier, for the link budget
    bandwidth_hz: float = 5000.0

    def on_air_bytes(self, size_bytes: int) -> int:
        if self.frame_bytes is None:
            return size_bytes
        return self.frame_bytes * max(1, math.ceil(size_bytes / self.frame_bytes))

    def airtime(self, size_bytes: int) -> float:
        """Seconds the packet occupies the channel, preamble included."""
        if self.bitrate is None:
            return self.preamble
        return self.preamble + 8.0 * self.on_air_bytes(size_bytes) / self.bitrate


PRESETS: dict[str, ModemParams] = {
    "ideal": ModemParams(),
    # WHOI Micro-Modem rate 0: 80 bit/s FH-FSK, one 32-byte frame (about 3.2 s of data); FSK bandwidth 4 kHz.
    # Preamble not given in the reference: 0.
    "whoi_micromodem_rate0": ModemParams(
        bitrate=80.0, frame_bytes=32, max_bytes=32, half_duplex=True, collisions=True,
        modulation="fsk", frequency_khz=25.0, bandwidth_hz=4000.0,
    ),
    # WHOI Micro-Modem rate 6: 490 bit/s PSK, 6 x 32-byte frames, 2.95 s (3.25 s with the 0.3 s probe).
    "whoi_micromodem_rate6": ModemParams(
        bitrate=490.0, preamble=0.3, frame_bytes=192, max_bytes=192, half_duplex=True, collisions=True,
        modulation="bpsk", frequency_khz=25.0, bandwidth_hz=5000.0,
    ),
    # USMART nanomodem v3: 640 bit/s raw, packets up to 64 bytes. Carrier and bandwidth not given: defaults.
    "usmart_nanomodem": ModemParams(bitrate=640.0, max_bytes=64, half_duplex=True, collisions=True),
    # UnetStack's example modems: 5 ms preamble; 800 bit/s with 16-byte frames, 2400 bit/s with 64-byte frames.
    "unet_800": ModemParams(bitrate=800.0, preamble=0.005, frame_bytes=16, half_duplex=True, collisions=True),
    "unet_2400": ModemParams(bitrate=2400.0, preamble=0.005, frame_bytes=64, half_duplex=True, collisions=True),
}  # fmt: skip


def modem(preset: str, **overrides: object) -> ModemParams:
    """A named preset with some fields replaced (None values leave the preset's)."""
    changes = {k: v for k, v in overrides.items() if v is not None}
    return replace(PRESETS[preset], **changes)  # type: ignore[arg-type]

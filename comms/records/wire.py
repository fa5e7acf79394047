"""The coordination message as an acoustic modem carries it: 15 bytes, not a JSON document.

    sender u8 | seq u16 (wraps) | time u32 (ms) | gamma f32 | gamma_dot f32        little-endian

A fleet with a vehicle id above 255 sends the sender as u16 instead (16 bytes, every vehicle of that fleet alike):
a fleet that fits in a byte keeps the 15 bytes, and so the airtimes and records it always had.

Its length is the packet size the channel charges airtime for, and receivers get the decoded (rounded) values:
gamma in float32 keeps about 7 significant digits, enough for coordination errors down to 1e-4 at gamma ~ 400.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable

import msgspec

from comms.records.ids import NARROW_IDS
from comms.records.records import Transmission

NARROW = struct.Struct("<BHIff")  # 15 bytes: every id of the fleet fits in one
WIDE = struct.Struct("<HHIff")  # 16 bytes
SIZE = NARROW.size  # 15 bytes: the message of a fleet whose ids fit in a byte


class Decoded(msgspec.Struct, frozen=True):
    sender: int
    seq: int
    t: float
    gamma: float
    gamma_dot: float


def wide_for(ids: Iterable[int]) -> bool:
    """Whether a fleet with these vehicle ids sends the wide message (a sender in two bytes)."""
    return max(ids, default=0) > NARROW_IDS


def layout(wide: bool = False) -> struct.Struct:
    return WIDE if wide else NARROW


def message_size(wide: bool = False) -> int:
    return layout(wide).size


def encode_coordination(tx: Transmission, wide: bool = False) -> bytes:
    return layout(wide).pack(tx.sender, tx.seq % 65536, round(tx.data_time * 1000.0), tx.gamma, tx.gamma_dot)


def decode_coordination(data: bytes, wide: bool = False) -> Decoded:
    sender, seq, t_ms, gamma, gamma_dot = layout(wide).unpack(data)
    return Decoded(sender, seq, t_ms / 1000.0, gamma, gamma_dot)


def carried(data: bytes, wide: bool = False) -> tuple[float, float]:
    """The (gamma, gamma_dot) decode_coordination reads, without the rest of the record: the broker's per packet."""
    _, _, _, gamma, gamma_dot = layout(wide).unpack(data)
    return gamma, gamma_dot

"""The coordination message as an acoustic modem carries it: 15 bytes, not a JSON document.

    sender u8 | seq u16 (wraps) | time u32 (ms) | gamma f32 | gamma_dot f32        little-endian

Its length is the packet size the channel charges airtime for, and receivers get the decoded (rounded) values:
gamma in float32 keeps about 7 significant digits, enough for coordination errors down to 1e-4 at gamma ~ 400.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from comms.records.records import Transmission

LAYOUT = struct.Struct("<BHIff")
SIZE = LAYOUT.size  # 15 bytes
MAX_VEHICLE_ID = 255


@dataclass(frozen=True, slots=True)
class Decoded:
    sender: int
    seq: int
    t: float
    gamma: float
    gamma_dot: float


def encode_coordination(tx: Transmission) -> bytes:
    return LAYOUT.pack(tx.sender, tx.seq % 65536, round(tx.data_time * 1000.0), tx.gamma, tx.gamma_dot)


def decode_coordination(data: bytes) -> Decoded:
    sender, seq, t_ms, gamma, gamma_dot = LAYOUT.unpack(data)
    return Decoded(sender, seq, t_ms / 1000.0, gamma, gamma_dot)

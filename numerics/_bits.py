"""Exact access to the two 32-bit words of an IEEE-754 double, as fdlibm's INSERT_WORDS and SET_LOW_WORD.

Only packing and unpacking of bits: no rounding happens here.
"""

import struct

_DOUBLE = struct.Struct("<d")
_UINT64 = struct.Struct("<Q")
_HIGH_MASK = 0xFFFFFFFF00000000


def from_words(high: int, low: int) -> float:
    """The double with high word high and low word low (fdlibm's INSERT_WORDS)."""
    value: float = _DOUBLE.unpack(_UINT64.pack((high << 32) | low))[0]
    return value


def clear_low_word(x: float) -> float:
    """x with its low word set to zero (fdlibm's SET_LOW_WORD(x, 0))."""
    value: float = _DOUBLE.unpack(_UINT64.pack(_UINT64.unpack(_DOUBLE.pack(x))[0] & _HIGH_MASK))[0]
    return value

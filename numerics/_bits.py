"""Exact access to the two 32-bit words of an IEEE-754 double, as fdlibm's GET_HIGH_WORD and friends.

Only packing and unpacking of bits: no rounding happens here.
"""

import struct

_DOUBLE = struct.Struct("<d")
_UINT64 = struct.Struct("<Q")
_LOW_MASK = 0xFFFFFFFF
_HIGH_MASK = 0xFFFFFFFF00000000


def to_bits(x: float) -> int:
    """The 64 bits of x as an unsigned integer."""
    bits: int = _UINT64.unpack(_DOUBLE.pack(x))[0]
    return bits


def from_bits(bits: int) -> float:
    """The double whose 64 bits are the unsigned integer bits."""
    value: float = _DOUBLE.unpack(_UINT64.pack(bits))[0]
    return value


def from_words(high: int, low: int) -> float:
    """The double with high word high and low word low (fdlibm's INSERT_WORDS)."""
    return from_bits((high << 32) | low)


def high_word(x: float) -> int:
    """The high word of x, signed as fdlibm's int32_t (GET_HIGH_WORD)."""
    high = to_bits(x) >> 32
    return high - 0x100000000 if high & 0x80000000 else high


def clear_low_word(x: float) -> float:
    """x with its low word set to zero (fdlibm's SET_LOW_WORD(x, 0))."""
    return from_bits(to_bits(x) & _HIGH_MASK)


def with_high_word(x: float, high: int) -> float:
    """x with its high word replaced by high, the low word kept (fdlibm's SET_HIGH_WORD)."""
    return from_bits(((high & _LOW_MASK) << 32) | (to_bits(x) & _LOW_MASK))

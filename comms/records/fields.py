"""Reading a message as the msgspec Struct that describes it (`read_as`) and writing it back (`as_message`), the
checks as msgspec types the structs share (Finite, NonNegative, Count, ...), and the few checks a type cannot say
(a rotation, a speed), which the structs' check() methods call.

Each raises ValueError naming the field for anything malformed: receivers count and drop such messages.
"""

from __future__ import annotations

import math
import re
import sys
import threading
from collections.abc import Callable, Sequence
from typing import Annotated, Any, TypeVar

import msgspec

from comms.records.bounded import MALFORMED, dropped
from comms.records.stream import NOT_FINITE

Message = dict[str, Any]
T = TypeVar("T")
MAX_SPEED = 100.0  # m/s: far above any AUV, far below the speed of sound
MAX_FLOAT32 = 3.4e38  # what the frame's float32 fields hold
MAX_TIME = (2**32 - 1) / 1000.0  # s: the frame's u32 millisecond time stamp

# Checks as msgspec types (annotations on the records; mypy sees float and int).
Finite = Annotated[float, msgspec.Meta(ge=-sys.float_info.max, le=sys.float_info.max)]  # NaN and inf fail both
Finite3 = tuple[Finite, Finite, Finite]
NonNegative = Annotated[float, msgspec.Meta(ge=0.0, le=sys.float_info.max)]  # a time, a delay
Count = Annotated[int, msgspec.Meta(ge=0)]
# A diagnostic: any float, or an integer within int64.
Real = Annotated[int, msgspec.Meta(ge=-(2**63) + 1, le=2**63 - 1)] | float
Real3 = tuple[Real, Real, Real]


def read_as(message: object, kind: type[T]) -> T:
    """The record `kind` (a msgspec Struct: its message's only description) of a message, checked by its types;
    ValueError naming the field for anything malformed, in msgspec's words ("field 't': Expected `float`, got `str`
    - at `$.t`")."""
    try:
        return msgspec.convert(message, kind) if kind in _BUILT else _first_conversion(message, kind)
    except msgspec.ValidationError as exc:
        reason = _named(str(exc))
        raise dropped(NOT_FINITE if _not_finite(message, reason) else MALFORMED, reason) from None


# msgspec (0.22) builds a struct type's conversion info on its first conversion, and threads that race there crash
# the process: 50 threads converting their first RxBatch at once segfaulted 24 of 40 times (a vehicle host's 50
# sessions at a run's start: 3 of 12 runs of 100 AUVs). Each type's first conversion is made under a lock.
_BUILT: set[type] = set()
_FIRST = threading.Lock()


def _first_conversion(message: object, kind: type[T]) -> T:
    with _FIRST:
        try:
            return msgspec.convert(message, kind)
        finally:
            _BUILT.add(kind)  # built, whether this message converted or not


def _not_finite(message: object, reason: str) -> bool:
    """Whether the top-level field msgspec's reason is about holds a NaN or an infinity (a Finite field refused)."""
    found = re.match(r"field '(\w+)'", reason)
    value = message.get(found.group(1)) if found is not None and isinstance(message, dict) else None
    values = value if isinstance(value, list) else [value]
    return any(isinstance(v, float) and not math.isfinite(v) for v in values)


def read_as_or_older(message: object, kind: type[T], older: Callable[[object], object | None]) -> T:
    """read_as, and if the message does not read, its older log's form converted by `older` (None: not an older
    form either: the first error stands)."""
    try:
        return read_as(message, kind)
    except ValueError:
        converted = older(message)
        if converted is None:
            raise
        return read_as(converted, kind)


def _named(reason: str) -> str:
    """msgspec's reason, led by the field of the message it is about (a missing one, or the top-level field its path
    starts with), as the hand-written checks named it."""
    found = re.search(r"`\$\.(\w+)", reason) or re.search(r"missing required field `([^`]+)`", reason)
    return reason if found is None else f"field {found.group(1)!r}: {reason}"


def get(message: Message, name: str, kind: type | tuple[type, ...]) -> Any:
    if name not in message:
        raise ValueError(f"missing field {name!r}")
    value = message[name]
    if isinstance(value, bool) and kind is not bool:
        raise ValueError(f"field {name!r} is a bool")
    if not isinstance(value, kind):
        raise ValueError(f"field {name!r} has type {type(value).__name__}")
    return value


def slow_enough(name: str, value: tuple[float, float, float]) -> tuple[float, float, float]:
    if math.hypot(*value) > MAX_SPEED:
        raise ValueError(f"field {name!r} is faster than {MAX_SPEED:g} m/s")
    return value


def orthonormal(r: Sequence[float]) -> None:
    """ValueError unless R (row-major, 9 numbers) has R R' = I to 1e-6. Written out, and each of the 6 distinct
    products of rows once (R R' is symmetric, and the same sums in the same order): it runs on every state."""
    a, b, c, d, e, f, g, h, i = r
    if (
        abs(a * a + b * b + c * c - 1.0) > 1e-6
        or abs(d * d + e * e + f * f - 1.0) > 1e-6
        or abs(g * g + h * h + i * i - 1.0) > 1e-6
        or abs(a * d + b * e + c * f) > 1e-6
        or abs(a * g + b * h + c * i) > 1e-6
        or abs(d * g + e * h + f * i) > 1e-6
    ):
        raise ValueError("field 'rotation' is not a rotation matrix")


def is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _number(value: object) -> float:
    """msgspec's hook for what it does not encode itself: a numpy float (a channel's arithmetic gives them), as the
    float it is; anything else is refused (TypeError)."""
    if isinstance(value, float):  # numpy.float64 subclasses float, and holds the same double
        return float(value)
    raise TypeError(f"cannot encode {type(value).__name__}")


_ENCODE = msgspec.msgpack.Encoder(enc_hook=_number).encode
_AS_BUILTINS = msgspec.msgpack.Decoder()  # untyped: dicts, lists and numbers


def as_message(record: msgspec.Struct) -> Message:
    """A struct's message: its fields as JSON types, in order, lists where msgspec.to_builtins would keep tuples,
    the optional fields left out where the struct omits its defaults."""
    message: Message = _AS_BUILTINS.decode(_ENCODE(record))
    return message

"""A bounded memo for the checks that solve the same physics for alike vehicles (vehicles.trim and vehicles.turn:
a fleet of one model on parallel paths needs one solution, not one a vehicle)."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

T = TypeVar("T")
KEPT = 4096  # solutions a memo holds at most: a long sweep in one process starts again rather than grow


class Memo(Generic[T]):
    """make()'s value by key, computed once; a key that does not hash (someone else's model) is not kept."""

    def __init__(self) -> None:
        self._kept: dict[Hashable, T] = {}

    def get(self, key: tuple[object, ...], make: Callable[[], T]) -> T:
        try:
            known = key in self._kept
        except TypeError:
            return make()
        if not known:
            if len(self._kept) >= KEPT:
                self._kept.clear()
            self._kept[key] = make()
        return self._kept[key]

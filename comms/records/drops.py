"""What a reader of the bus dropped, counted where it happens: by key and by cause (the names of
comms.records.bounded and comms.records.stream, the same in the supervisor, the broker and the vehicles), with the
first few told in the log and the rest only counted, so that a flood of bad messages costs a counter, not a log.
"""

from __future__ import annotations

import logging
from collections import Counter

from comms.records.bounded import cause_of
from comms.records.reports import MAX_KEYS

OTHER_KEYS = "other keys"  # an end-of-run report's entry for the keys past its MAX_KEYS - 1 largest

LOGGED = 20  # drops a reader tells one by one; the others are only counted (and their number told at the end)


class Drops:
    """One reader's drops: `by_key` (key -> messages) and `by_cause` (cause -> messages)."""

    def __init__(self, log: logging.Logger, reader: str, level: int = logging.WARNING) -> None:
        self.by_key: Counter[str] = Counter()
        self.by_cause: Counter[str] = Counter()
        self.last: dict[str, str] = {}  # key -> why its latest drop was dropped (a stall names it)
        self._log, self._reader, self._level = log, reader, level

    def drop(self, key: str, exc: BaseException, what: str = "message") -> None:
        """Count a dropped message (or part of one: what) on key, under the cause exc names; tell the first LOGGED."""
        cause = cause_of(exc)
        self.by_key[key] += 1
        self.by_cause[cause] += 1
        self.last[key] = f"{cause}: {exc}"
        total = self.by_key.total()
        if total <= LOGGED:
            self._log.log(self._level, "%s: dropped a %s on %s (%s): %s", self._reader, what, key, cause, exc)
            if total == LOGGED:
                self._log.log(self._level, "%s: further drops only counted (the run's end tells)", self._reader)

    @property
    def total(self) -> int:
        return self.by_key.total()

    def reported(self) -> tuple[dict[str, int], dict[str, int]]:
        """(by key, by cause) as an end-of-run report carries them, sorted: past MAX_KEYS keys (drops on the keys of
        many vehicles: a report that long does not read) the MAX_KEYS - 1 with the most, the rest as OTHER_KEYS."""
        keys = self.by_key
        if len(keys) > MAX_KEYS:
            kept = dict(keys.most_common(MAX_KEYS - 1))
            keys = Counter({**kept, OTHER_KEYS: keys.total() - sum(kept.values())})
        return dict(sorted(keys.items())), dict(sorted(self.by_cause.items()))

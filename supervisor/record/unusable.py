"""Records a log reader cannot use (a field a record's type refuses: a null where a number must be, from a log written
before the intake dropped non-finite values; a record of another version): each named, counted and skipped, so that
one bad record costs that record, not the whole log. The first few are told (a warning each), then only their number.
"""

from __future__ import annotations

import logging
from pathlib import Path

from comms.records.bounded import brief

log = logging.getLogger("cpf.log")
TOLD = 20  # unusable records told one by one; the others only counted


class Unusable:
    """One reading of one log: the records it skipped, by topic."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.by_topic: dict[str, int] = {}

    def skip(self, topic: str, exc: ValueError) -> None:
        """A record of topic that does not read (exc says why): told if among the first TOLD, counted, skipped."""
        self.by_topic[topic] = self.by_topic.get(topic, 0) + 1
        if self.total <= TOLD:
            log.warning("%s: skipped a record on %s that does not read: %s", self.path, topic, brief(str(exc)))

    @property
    def total(self) -> int:
        return sum(self.by_topic.values())

    def close(self) -> None:
        """The count, if any record was skipped: what the reading's results leave out."""
        if self.by_topic:
            topics = ", ".join(f"{n} on {topic}" for topic, n in sorted(self.by_topic.items()))
            log.warning("%s: %d records skipped as they do not read (%s)", self.path, self.total, topics)

"""The broker's link events of one step as the bus carries them (cpf/comms/events): one message a step, where the
log keeps one cpf/comms/event record per event (comms.records.records.LinkEvent). The record, its wire form and its
checked reading side by side.
"""

from __future__ import annotations

from dataclasses import dataclass

from comms.records.fields import Message, get, number
from comms.records.records import LinkEvent


@dataclass(frozen=True, slots=True)
class LinkEvents:
    """The link events the broker publishes with the tick of step k (t: that tick's time)."""

    t: float
    k: int
    events: tuple[LinkEvent, ...]

    def to_message(self) -> Message:
        return {"t": self.t, "k": self.k, "events": [event.to_message() for event in self.events]}

    @classmethod
    def from_message(cls, message: Message, malformed: list[ValueError] | None = None) -> LinkEvents:
        """The batch, checked: ValueError naming the field for anything malformed. With a malformed list, an event
        that does not read is left out and its error appended there instead (the rest of the batch still counts:
        a reader that counts the events the broker announced counts it too)."""
        t, k, items = number(message, "t"), get(message, "k", int), get(message, "events", list)
        if not all(isinstance(item, dict) for item in items):
            raise ValueError("field 'events' has an item that is not a map")
        events = []
        for n, item in enumerate(items):
            try:
                events.append(LinkEvent.from_message(item))
            except ValueError as exc:
                if malformed is None:
                    raise ValueError(f"field 'events': item {n}: {exc}") from None
                malformed.append(exc)
        return cls(t, k, tuple(events))

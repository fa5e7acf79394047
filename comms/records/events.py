"""The broker's link events of one step as the bus carries them (cpf/comms/events): one message a step, where the
log keeps one cpf/comms/event record per event (comms.records.records.LinkEvent). A msgspec Struct, the message's only
description: its message, its checked reading and its schema (comms.records.schemas.LINK_EVENTS) come from it.
"""

from __future__ import annotations

import msgspec

from comms.records.fields import Finite, Message, as_message, read_as
from comms.records.records import LinkEvent


class LinkEvents(msgspec.Struct, frozen=True):
    """The link events the broker publishes with the tick of step k (t: that tick's time)."""

    t: Finite
    k: int
    events: tuple[LinkEvent, ...]

    def to_message(self) -> Message:
        return as_message(self)

    @classmethod
    def from_message(cls, message: object, malformed: list[ValueError] | None = None) -> LinkEvents:
        """The batch, checked: ValueError naming the field for anything malformed. With a malformed list, an event
        that does not read is left out and its error appended there instead (the rest of the batch still counts:
        a reader that counts the events the broker announced counts it too)."""
        try:
            return read_as(message, cls)
        except ValueError:
            items = message.get("events") if malformed is not None and isinstance(message, dict) else None
            if malformed is None or not isinstance(items, list) or not all(isinstance(item, dict) for item in items):
                raise
        assert isinstance(message, dict)
        frame = read_as({**message, "events": []}, cls)  # the batch but its events
        events = []
        for item in items:
            try:
                events.append(LinkEvent.from_message(item))
            except ValueError as exc:
                malformed.append(exc)
        return msgspec.structs.replace(frame, events=tuple(events))

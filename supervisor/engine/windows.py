"""Lockstep time windows: the rule lives in comms.broker.windows, where the broker, which works out the windows of a
span itself (comms.broker.span), can reach it too."""

from comms.broker.windows import Reports, window_end, worth_waiting

__all__ = ["Reports", "window_end", "worth_waiting"]

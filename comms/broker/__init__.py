"""The acoustic-link broker: its process, its sync step over the channel, lockstep windows and spans, and the
per-link statistics of a run. The top of comms: it uses the channel, the bus and the records."""

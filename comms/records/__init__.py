"""Records and messages: what travels on the bus and lands in the log, each record with its wire form and checked
reading (keys and messages, state, receptions, tick, network, reports, link events, JSON Schemas, the modem's bytes).
The lowest of comms' concepts: the channel, the bus and the broker all build on it; it imports none of them."""

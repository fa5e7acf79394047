"""The acoustic channel as pure, seeded models: propagation, the link budget, fading, loss, modems, and the channel
that decides who hears a transmission, when, or why not (and the guard around someone else's loss model).
Builds on the records; knows nothing of the bus."""

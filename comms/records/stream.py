"""A vehicle's stream of steps, as every reader of it holds it (the supervisor's intake and the broker): each step
once, in order, and none beyond the steps the clock granted. Anything else is a ValueError naming its cause
(comms.records.bounded.dropped), with the same names everywhere (comms.records.drops counts them): a replay of a step
already taken, or a flood of copies of one, costs a counter, never a record, a second delivery or memory.
"""

from __future__ import annotations

from comms.records.bounded import dropped

REPLAYED = "replayed step"  # a step older than or equal to the vehicle's latest taken
STALE = "stale step"  # a step the reader is already past (its transmissions in the water, or before its start)
BEYOND_WINDOW = "beyond the window"  # a step the clock has not granted yet
OUT_OF_TURN = "out of turn"  # a step that skips one the vehicle has still to send (each step once, in order)
NOT_FINITE = "not finite"  # NaN or inf where a number must be one (comms.records.fields.Finite)
IMPLAUSIBLE = "implausible"  # beyond what the vehicle's own model and the step allow (supervisor.config.plausibility)
FAULTY = "faulty vehicle"  # anything more from a vehicle whose state was not finite or implausible: it is lost
VEHICLE_FAULTS = (NOT_FINITE, IMPLAUSIBLE)  # causes that make a vehicle's state its fault (on_vehicle_loss decides)


def in_stream(
    k: int, taken: int | None, granted: int | None, past: int | None = None, first: int | None = None
) -> None:
    """ValueError (dropped) unless the steps first .. k of one message (first None: k alone) are the vehicle's next:
    after its latest taken step (taken; None: none yet, any first step is taken) and the step the reader is past
    (past; None: nothing), the first of them right after the later of the two (once one is taken), and k before the
    first step the clock has not granted (granted; None: not known to this reader). A vehicle sends every step once,
    in order: a step that skips one it has still to send is not its own (whoever holds its credential sent it ahead),
    and taking it would turn the vehicle's own into a replay, a step the reader would wait for forever, and the
    whole fleet with it."""
    first = k if first is None else first
    if taken is not None and first <= taken:  # first: a replay is named as such by every reader
        raise dropped(REPLAYED, f"step {first} is not after step {taken}, already taken from this vehicle")
    if past is not None and first <= past:
        raise dropped(STALE, f"step {first} is not after step {past}, already past")
    if granted is not None and k >= granted:
        raise dropped(BEYOND_WINDOW, f"step {k} is beyond the steps granted (up to {granted - 1})")
    after = taken if past is None or taken is None else max(taken, past)  # a restarted vehicle's: after past
    if after is not None and first != after + 1:
        raise dropped(OUT_OF_TURN, f"step {first} skips step {after + 1}, the vehicle's next")


def at_step_time(t: float, k: int, dt: float, what: str) -> None:
    """ValueError unless t is the time of step k, k dt up to rounding (the clock's t of a step is its tick's, a
    multiple of dt added up or multiplied out)."""
    if abs(t - k * dt) > 1e-9 * max(1.0, k * dt):
        raise ValueError(f"{what} t = {t:g} s is not the time of step {k} ({k * dt:g} s)")

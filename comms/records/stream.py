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
NOT_FINITE = "not finite"  # NaN or inf where a number must be one (comms.records.fields.Finite)
IMPLAUSIBLE = "implausible"  # beyond what the vehicle's own model and the step allow (supervisor.config.plausibility)
FAULTY = "faulty vehicle"  # anything more from a vehicle whose state was not finite or implausible: it is lost
VEHICLE_FAULTS = (NOT_FINITE, IMPLAUSIBLE)  # causes that make a vehicle's state its fault (on_vehicle_loss decides)


def in_stream(k: int, taken: int | None, granted: int | None, past: int | None = None) -> None:
    """ValueError (dropped) unless step k comes after the vehicle's latest taken step (taken; None: none yet), after
    the step the reader is past (past; None: nothing), and before the first step the clock has not granted (granted;
    None: not known to this reader)."""
    if taken is not None and k <= taken:  # first: a replay is named as such by every reader
        raise dropped(REPLAYED, f"step {k} is not after step {taken}, already taken from this vehicle")
    if past is not None and k <= past:
        raise dropped(STALE, f"step {k} is not after step {past}, already past")
    if granted is not None and k >= granted:
        raise dropped(BEYOND_WINDOW, f"step {k} is beyond the steps granted (up to {granted - 1})")


def at_step_time(t: float, k: int, dt: float, what: str) -> None:
    """ValueError unless t is the time of step k, k dt up to rounding (the clock's t of a step is its tick's, a
    multiple of dt added up or multiplied out)."""
    if abs(t - k * dt) > 1e-9 * max(1.0, k * dt):
        raise ValueError(f"{what} t = {t:g} s is not the time of step {k} ({k * dt:g} s)")

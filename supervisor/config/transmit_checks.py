"""What [comms.transmit] asks of its policy: errors where a built-in policy cannot do it as written, warnings for
keys the policy does not read.

The keys of both built-in policies sit side by side in [comms.transmit], so a key of the other one (heartbeat under
"periodic", period under "event", either under an extension, which reads only `options`) was accepted and ignored:
a user who wrote heartbeat = 0.5 expects a message at least every 0.5 s (a new user). A key counts as given when
the file or a --set wrote it (pydantic's model_fields_set), whatever its value: the keys have defaults, and writing
the default is no less a sign of expecting it to act.
"""

from __future__ import annotations

from collections.abc import Iterator

from supervisor.config.derived import STEP_TOLERANCE, whole_steps
from supervisor.config.scenario_schema import Scenario

PERIODIC_KEYS = ("period",)
EVENT_KEYS = ("threshold", "threshold_decay", "decay_rate", "min_interval", "heartbeat")
READS = {"periodic": PERIODIC_KEYS, "event": EVENT_KEYS}  # the keys each built-in policy reads (config.fleet)


def transmit_errors(sc: Scenario) -> Iterator[str]:
    """What the built-in policies cannot do as written: send more often than once a step, or promise a message at
    least every heartbeat while waiting longer than that between two (accepted, and not done)."""
    tx, dt = sc.comms.transmit, sc.scenario.step
    if tx.policy == "periodic" and tx.period is not None and tx.period < dt * (1 - STEP_TOLERANCE):
        yield f"comms.transmit.period: at least the step ({dt:g} s): one message a step at most, got {tx.period}"
    elif tx.policy == "periodic" and tx.period is not None and not whole_steps(tx.period, dt):
        yield f"comms.transmit.period: must be a whole number of steps ({dt:g} s), got {tx.period}"
    if tx.policy == "event" and tx.heartbeat is not None and tx.heartbeat < tx.min_interval:
        yield f"comms.transmit.heartbeat: at least min_interval ({tx.min_interval:g} s), got {tx.heartbeat}"
    for key in ("min_interval", "heartbeat"):
        value = getattr(tx, key)
        if tx.policy == "event" and value and not whole_steps(value, dt):
            yield f"comms.transmit.{key}: must be a whole number of steps ({dt:g} s), got {value}"


def transmit_warnings(sc: Scenario) -> list[str]:
    """'comms.transmit.<key>: ... has no effect ..., got <value>' for each key given that the policy does not read."""
    tx = sc.comms.transmit
    reads = READS.get(tx.policy, ())
    out = []
    for key in (*PERIODIC_KEYS, *EVENT_KEYS):
        if key in tx.model_fields_set and key not in reads:
            owner = "periodic" if key in PERIODIC_KEYS else "event"
            reader = "" if tx.policy in READS else " (it reads only comms.transmit.options)"
            out.append(
                f"comms.transmit.{key}: a key of the {owner} policy, it has no effect under policy "
                f"{tx.policy!r}{reader}, got {getattr(tx, key)}"
            )
    return out

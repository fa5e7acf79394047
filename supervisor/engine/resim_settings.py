"""What `cpf resim` can change: the one table its check (supervisor/engine/resim.py) and its --help text both read.

Re-simulation replays the receptions a run recorded, so only settings that act inside a vehicle can apply. Kept apart
from supervisor/engine/resim.py so that building the command line's help does not import the simulation (every `cpf`
process, the vehicles' too, builds it).
"""

from __future__ import annotations

from pathlib import Path

from supervisor.errors import ScenarioError

# The settings resim can apply: key pattern ("#" a list index, "*" anything below) and what it changes.
SETTINGS: tuple[tuple[str, str], ...] = (
    ("coordination.*", "the coordination law, gains, reference speed and predictor"),
    ("path_following.*", "the path-following gains and offset delta"),
    ("vehicle.*", "the vehicle model: preset and parameter overrides"),
    ("vehicles.#.position", "a vehicle's initial state"),
    ("vehicles.#.attitude_rpy_deg", "a vehicle's initial state"),
    ("vehicles.#.velocity", "a vehicle's initial state"),
    ("vehicles.#.angular_velocity", "a vehicle's initial state"),
    ("vehicles.#.gamma0", "a vehicle's initial path parameter"),
    ("vehicles.#.path.*", "a vehicle's path"),
    ("report.*", "the summary's transient, tube margin and coordination tolerance"),
    ("scenario.duration", "shorter than recorded only: the summary over the start of the run"),
)
# Why the others cannot apply, by the first part of their key.
REFUSED = {
    "comms": "the channel is not simulated again: the vehicles hear the receptions recorded",
    "graph": "who hears whom is recorded in the receptions",
    "faults": "the fault schedule shaped the receptions and who was alive when, as recorded",
    "scenario": "the step, seed and timing are the recording's",
    "vehicles": "the fleet (vehicle ids, their number) is the recording's",
}


def settings_help() -> str:
    """The settings resim can apply, for `cpf resim --help`."""
    return ", ".join(pattern.replace("#", "N") for pattern, _ in SETTINGS)


def help_text() -> str:
    """The --set help of `cpf resim`."""
    return (
        f"what to change (repeatable); only what acts inside a vehicle: {settings_help()}; the rest "
        f"({', '.join(f'{part}.*' for part in REFUSED)}) is refused: the recorded receptions would not follow it"
    )


def check_override(log: Path, override: str) -> None:
    """ScenarioError unless override (KEY=VALUE) is a setting resim can apply."""
    key = override.partition("=")[0].strip()
    if not any(_matches(pattern, key) for pattern, _ in SETTINGS):
        why = REFUSED.get(key.split(".")[0], "not a setting of the vehicles")
        raise ScenarioError(
            f"{log}: --set {override.strip()}: resim cannot apply it ({why}); it can apply {settings_help()}"
        )


def _matches(pattern: str, key: str) -> bool:
    """Whether a dotted key is the pattern's place ("#": any list index) or, for "prefix.*", at or below it."""
    want, have = pattern.split("."), key.split(".")
    if want[-1] == "*":
        want = want[:-1]
        have = have[: len(want)]
    return len(want) == len(have) and all(w == h or (w == "#" and h.isdigit()) for w, h in zip(want, have, strict=True))

"""Which scenario a process runs, as a digest: every process of a run must run the supervisor's.

The digest is the sha256 of a canonical JSON (sorted keys, no spaces, floats as Python writes them: the same text on
every host) of the validated Scenario, --set and --fault applied, so two files that differ only in comments, key
order or spelling of numbers (1 vs 1.0) give the same digest. Each top-level section has its own digest too, so a
mismatch can be named ("coordination differs"). The broker draws the channel's randomness from the run's seed: its
digest covers the seed as well (section "seed"), and so does a vehicle's with navigation on (its sensor noise).
Section "extensions" covers the code the scenario's law, predictor, transmission policy, controller and vehicle models
resolve to on this host (name, class, distribution and version, hash of the module's source:
supervisor.config.extensions.Identity).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json

from comms.records.messages import ANOTHER_SCENARIO, Hello, Message
from supervisor.config.extension_checks import extension_identities
from supervisor.config.plant import spreads
from supervisor.config.scenario_schema import Scenario


def _sha(value: object) -> str:
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False, ensure_ascii=True)
    return hashlib.sha256(text.encode()).hexdigest()


def section_digests(scenario: Scenario, seed: int | None = None) -> dict[str, str]:
    """sha256 (hex) of each top-level section of the validated scenario, and of the seed if given."""
    dump = scenario.model_dump(mode="json")
    sections = {name: _sha(value) for name, value in dump.items()}
    # The code the scenario's extensions resolve to here: a process running other code is refused.
    sections["extensions"] = _sha([dataclasses.asdict(identity) for identity in extension_identities(scenario)])
    if seed is not None:
        sections["seed"] = _sha(seed)
    return sections


def digest(sections: dict[str, str]) -> str:
    """The digest of the whole: of the section digests (so it follows from them)."""
    return _sha(sections)


def vehicle_seed(scenario: Scenario, seed: int) -> int | None:
    """The seed a vehicle's digest covers: the run's if it draws from it (navigation noise, its plant's
    parameters), else none."""
    return seed if scenario.navigation is not None or spreads(scenario) else None


def hello(process: str, scenario: Scenario, seed: int | None = None) -> Message:
    """What a process answers when asked which scenario it runs."""
    sections = section_digests(scenario, seed)
    return Hello(process, digest(sections), sections).to_message()


def difference(name: str, expected: dict[str, str], got: Hello) -> str | None:
    """None if got is the expected scenario; else a one-line account naming the process, both digests and the
    sections that differ."""
    want = digest(expected)
    if got.digest == want and got.sections == expected:
        return None
    differ = sorted(k for k in expected.keys() | got.sections.keys() if expected.get(k) != got.sections.get(k))
    where = f"differs in {', '.join(differ)}" if differ else "differs"
    return (
        f"{name} {ANOTHER_SCENARIO} ({where}): digest {got.digest[:12]}, "
        f"expected {want[:12]}; start it with the supervisor's scenario file, --set and --fault"
    )

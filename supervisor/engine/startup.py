"""The start of a distributed run, the supervisor's side: who is still missing, and whether each process that came
alive runs the supervisor's scenario (its hello, comms.records.messages.Hello, against the expected digests)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from comms.records.messages import COMMS_ALIVE, Hello, decode, hello_key
from supervisor.config.scenario_digest import difference, section_digests, vehicle_seed
from supervisor.config.scenario_schema import Scenario
from supervisor.errors import ScenarioError

HELLO_TIMEOUT = 10.0  # s for a process that just declared its token to answer which scenario it runs
REPORT_EVERY = 5.0  # s between "waiting for ..." lines


def missing_names(names: list[str], remote: tuple[int, ...]) -> str:
    """'vehicles 2, 3 (started by hand), vehicle 4 and the comms broker' for process names as the supervisor
    keeps them ('vehicle 2', 'comms broker')."""
    vehicles = [int(n.split()[1]) for n in names if n.startswith("vehicle ")]
    by_hand = [v for v in vehicles if v in remote]
    parts = []
    for ids, how in ((by_hand, " (started by hand)"), ([v for v in vehicles if v not in by_hand], "")):
        if ids:
            parts.append(f"vehicle{'s' if len(ids) > 1 else ''} {', '.join(str(v) for v in sorted(ids))}{how}")
    parts += [f"the {n}" for n in names if not n.startswith("vehicle ")]
    return ", ".join(parts[:-1]) + (" and " if len(parts) > 1 else "") + parts[-1] if parts else "nothing"


def ask_hello(session: zenoh.Session, alive_key: str, timeout: float = HELLO_TIMEOUT) -> Hello | None:
    """The hello of the process holding alive_key; None if it does not answer (or answers nonsense)."""
    for reply in session.get(hello_key(alive_key), timeout=timeout):
        if reply.ok is not None:
            with contextlib.suppress(ValueError):
                return Hello.from_message(decode(reply.ok.payload.to_bytes()))
    return None


def check_hello(name: str, expected: dict[str, str], got: Hello | None) -> None:
    """ScenarioError unless the process runs the expected scenario (exit 2: it was started with other input)."""
    if got is None:
        raise ScenarioError(
            f"{name} did not say which scenario it runs (no answer on its hello key): it is not a cpf process of "
            "this version; refused"
        )
    mismatch = difference(name, expected, got)
    if mismatch is not None:
        raise ScenarioError(mismatch)


@dataclass(frozen=True, slots=True)
class Hellos:
    """Which scenario each process must prove it runs ("vehicle" / "comms": section digests; the broker's cover the
    seed), and how to ask a process for its hello by its liveliness key."""

    digests: dict[str, dict[str, str]]
    ask: Callable[[str], Hello | None]

    @classmethod
    def of(cls, sc: Scenario, seed: int, ask: Callable[[str], Hello | None]) -> Hellos:
        return cls({"vehicle": section_digests(sc, vehicle_seed(sc, seed)), "comms": section_digests(sc, seed)}, ask)

    def check(self, key: str, name: str) -> None:
        """ScenarioError unless the process holding liveliness key `key` runs the supervisor's scenario."""
        check_hello(name, self.digests["comms" if key == COMMS_ALIVE else "vehicle"], self.ask(key))

"""The start of a distributed run, the supervisor's side: who is still missing, and whether each process that came
alive runs the supervisor's scenario (its hello, comms.records.messages.Hello, against the expected digests)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from comms.records.bounded import cause_of
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


Answer = Hello | ValueError | None  # a process's hello, why its answer does not read, or None: no answer at all


def ask_hello(session: zenoh.Session, alive_key: str, timeout: float = HELLO_TIMEOUT) -> Answer:
    """The hello of the process holding alive_key; a ValueError (comms.records.bounded.dropped) if its answers do not
    read (the last one's, naming its cause), None if it does not answer."""
    refused: ValueError | None = None
    for reply in session.get(hello_key(alive_key), timeout=timeout):
        if reply.ok is not None:
            try:
                return read_hello(reply.ok.payload.to_bytes())
            except ValueError as exc:  # every refusal of the readers names its cause (comms.records.bounded)
                refused = exc
    return refused


def read_hello(payload: bytes) -> Hello:
    """A hello reply, read through the bounded reader; ValueError (naming its cause) for anything that is not one."""
    return Hello.from_message(decode(payload))


def check_hello(name: str, expected: dict[str, str], got: Answer) -> None:
    """ScenarioError unless the process runs the expected scenario (exit 2: it was started with other input)."""
    if isinstance(got, ValueError):
        raise ScenarioError(
            f"{name} answered on its hello key with what is not a hello ({cause_of(got)}: {got}); refused"
        )
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
    ask: Callable[[str], Answer]

    @classmethod
    def of(cls, sc: Scenario, seed: int, ask: Callable[[str], Answer]) -> Hellos:
        return cls({"vehicle": section_digests(sc, vehicle_seed(sc, seed)), "comms": section_digests(sc, seed)}, ask)

    def check(self, key: str, name: str) -> None:
        """ScenarioError unless the process holding liveliness key `key` runs the supervisor's scenario."""
        check_hello(name, self.digests["comms" if key == COMMS_ALIVE else "vehicle"], self.ask(key))

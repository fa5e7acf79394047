"""The run's metadata (cpf/run/meta), the first record of every log: what ran, with which seed and which versions.

A supervisor record (schema comms.records.schemas.META): it carries the scenario as validated, which the lower layers
know nothing of. `RunMeta.of` builds it from a scenario, `to_message` gives its wire form (JSON in the log, msgpack on
the bus), `from_message` is its checked inverse (ValueError naming the field) that every reader of a log goes through.
"""

from __future__ import annotations

import platform
from dataclasses import dataclass
from importlib import metadata
from typing import Any

from comms.records.fields import Message, get, is_int, number
from comms.records.run import Edge, edges_of, links_message
from supervisor.config.derived import tube_radius
from supervisor.config.extension_checks import extension_identities
from supervisor.config.scenario_schema import Scenario

META_NAMES = ("scenario_name", "scenario_file", "scenario_toml", "engine", "clock")  # the string fields


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "unknown"


@dataclass(frozen=True, slots=True)
class RunMeta:
    """What ran: the scenario (its name, file, text, and as validated with --set and --fault applied: enough to
    re-run it), the seed, engine and clock, and the numbers readers need without validating the scenario again."""

    scenario_name: str
    scenario_file: str
    scenario_toml: str
    scenario: dict[str, Any]
    seed: int
    engine: str
    clock: str
    step: float
    duration: float
    vehicles: tuple[int, ...]
    edges: tuple[Edge, ...]
    faults: tuple[dict[str, Any], ...]  # each fault's scenario fields, its kind included
    tube_radius: float
    versions: dict[str, str]
    extensions: tuple[str, ...] = ()  # what the scenario's extensions resolved to (Identity.describe)

    @classmethod
    def of(
        cls, scenario: Scenario, scenario_file: str, scenario_toml: str, seed: int, engine: str, clock: str
    ) -> RunMeta:
        versions = {"cpf-cosim": _version("cpf-cosim"), "python": platform.python_version(),
                    "numpy": _version("numpy"), "eclipse-zenoh": _version("eclipse-zenoh"),
                    "msgspec": _version("msgspec")}  # fmt: skip
        return cls(
            scenario.scenario.name, scenario_file, scenario_toml, scenario.model_dump(mode="json"), seed, engine,
            clock, scenario.scenario.step, scenario.scenario.duration, tuple(scenario.vehicle_ids),
            tuple((i, j) for i, j in scenario.graph.edges), tuple(f.model_dump() for f in scenario.faults),
            tube_radius(scenario), versions, tuple(i.describe() for i in extension_identities(scenario)),
        )  # fmt: skip

    def to_message(self) -> Message:
        return {
            "scenario_name": self.scenario_name,
            "scenario_file": self.scenario_file,
            "scenario_toml": self.scenario_toml,
            "scenario": self.scenario,
            "seed": self.seed,
            "engine": self.engine,
            "clock": self.clock,
            "step": self.step,
            "duration": self.duration,
            "vehicles": list(self.vehicles),
            "edges": links_message(self.edges),
            "faults": list(self.faults),
            "tube_radius": self.tube_radius,
            "versions": self.versions,
            "extensions": list(self.extensions),
        }

    @classmethod
    def from_message(cls, message: Message) -> RunMeta:
        """The metadata, checked: ValueError naming the field for anything malformed."""
        names = {name: get(message, name, str) for name in META_NAMES}
        vehicles = get(message, "vehicles", list)
        if not all(is_int(v) for v in vehicles):
            raise ValueError("field 'vehicles' is not a list of vehicle ids")
        faults = get(message, "faults", list)
        if not all(isinstance(f, dict) and isinstance(f.get("kind"), str) for f in faults):
            raise ValueError("field 'faults' is not a list of faults, each with its kind")
        versions = get(message, "versions", dict)
        if not all(isinstance(v, str) for v in versions.values()):
            raise ValueError("field 'versions' is not a map of package to version")
        extensions = message.get("extensions", [])  # absent in logs of cpf before extensions
        if not isinstance(extensions, list) or not all(isinstance(e, str) for e in extensions):
            raise ValueError("field 'extensions' is not a list of descriptions")
        step = number(message, "step")
        if step <= 0:
            raise ValueError(f"field 'step' is not positive, got {step}")
        return cls(
            names["scenario_name"], names["scenario_file"], names["scenario_toml"], get(message, "scenario", dict),
            get(message, "seed", int), names["engine"], names["clock"], step, number(message, "duration"),
            tuple(vehicles), edges_of(message, "edges"), tuple(faults), number(message, "tube_radius"), versions,
            tuple(extensions),
        )  # fmt: skip

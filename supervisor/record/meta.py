"""The run's metadata (cpf/run/meta), the first record of every log: what ran, with which seed and which versions.

Its message is described once, by comms.records.run.RunMeta (the message, its checked reading and its schema); here
it is built from a scenario, which the lower layers know nothing of (`RunMeta.of`).
"""

from __future__ import annotations

import functools
import platform
from importlib import metadata

from comms.records.run import RunMeta as _RunMeta
from comms.records.run import links
from supervisor.config.derived import tube_radius
from supervisor.config.extension_checks import extension_identities
from supervisor.config.scenario_schema import Scenario


@functools.cache  # installed versions do not change within a process (a sweep builds many metas)
def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "unknown"


class RunMeta(_RunMeta, frozen=True):
    """comms.records.run.RunMeta, built from a scenario."""

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
            links(scenario.graph.edges), tuple(f.model_dump() for f in scenario.faults), tube_radius(scenario),
            versions, tuple(i.describe() for i in extension_identities(scenario)),
        )  # fmt: skip

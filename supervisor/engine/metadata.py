"""Run metadata recorded at the start of every log: what ran, with which seed and which versions."""

from __future__ import annotations

import platform
from collections.abc import Iterable
from importlib import metadata

from comms.messages import Message
from supervisor.config.derived import tube_radius
from supervisor.config.scenario_schema import Scenario


def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "unknown"


def run_meta(scenario: Scenario, scenario_file: str, scenario_toml: str, seed: int, engine: str, clock: str) -> Message:
    return {
        "scenario_name": scenario.scenario.name,
        "scenario_file": scenario_file,
        "scenario_toml": scenario_toml,
        "scenario": scenario.model_dump(mode="json"),  # as validated, --set and --fault applied: enough to re-run
        "seed": seed,
        "engine": engine,
        "clock": clock,
        "step": scenario.scenario.step,
        "duration": scenario.scenario.duration,
        "vehicles": scenario.vehicle_ids,
        "edges": [list(e) for e in scenario.graph.edges],
        "faults": [f.model_dump() for f in scenario.faults],
        "tube_radius": tube_radius(scenario),
        "versions": {
            "cpf-cosim": _version("cpf-cosim"),
            "python": platform.python_version(),
            "numpy": _version("numpy"),
            "eclipse-zenoh": _version("eclipse-zenoh"),
        },
    }


def graph_message(t: float, edges: Iterable[tuple[int, int]]) -> Message:
    """The communication graph in force from time t."""
    return {"t": t, "edges": [list(e) for e in edges]}

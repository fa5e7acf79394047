"""Shared fixtures: the repository's scenario files, and shortened variants of them."""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

from comms.bus.bus import Publishers
from comms.records.events import logged_events
from comms.records.messages import Message
from comms.records.run import links
from supervisor.record.meta import RunMeta

# Property tests draw the same examples on every run (derandomize): a clean clone's `make test` fails because of a
# change, not because a random draw found an old bug that day. To search further, run with
# HYPOTHESIS_PROFILE=explore (random draws, each time others) and pin what it finds with @example.
settings.register_profile("default", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"


def shortened(text: str, duration: float) -> str:
    """A scenario text with its duration replaced."""
    return re.sub(r"(?m)^duration = .*$", f"duration = {duration}", text, count=1)


def link_events(logged: Iterable[tuple[str, int, Any]]) -> list[Any]:
    """Every link event of a log's records (read_messages), each at its own t, in log order: a step's batch
    (cpf/comms/events) taken apart, an older log's single records (cpf/comms/event) as they are."""
    return [event for topic, _, message in logged for event in logged_events(topic, message)]


@pytest.fixture
def paper_text() -> str:
    return (CONFIGS / "paper.toml").read_text()


class RecordingPublishers(Publishers):
    """What a process would publish, kept in a list (no Zenoh session)."""

    def __init__(self) -> None:
        self.messages: list[tuple[str, Message]] = []

    def put(self, key: str, message: Message) -> None:
        self.messages.append((key, message))


def run_meta(**fields: Any) -> RunMeta:
    """A run's metadata record for synthetic runs: these fields, neutral values for the rest (no scenario: readers
    fall back to the meta's own fields)."""
    base: dict[str, Any] = {
        "scenario_name": "synthetic", "scenario_file": "synthetic.toml", "scenario_toml": "", "scenario": {},
        "seed": 0, "engine": "inprocess", "clock": "lockstep", "step": 1.0, "duration": 100.0, "vehicles": (),
        "edges": (), "faults": (), "tube_radius": math.nan, "versions": {},
    }  # fmt: skip
    given = base | fields
    return RunMeta(**{name: value for name, value in given.items() if name != "edges"}, links=links(given["edges"]))


@pytest.fixture(scope="session")
def every_kind_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The paper scenario cut to 60 s, one fault of every kind (tests/test_faults_e2e.EVERY_KIND), vehicle loss
    'continue', run by `cpf run` on each engine: {"scenario": its file, "args": the run's options, engine: (log, the
    finished cpf run)}. test_faults_e2e and test_foxglove_log read the same two logs (once per xdist worker)."""
    from tests.procs import cpf
    from tests.test_faults_e2e import EVERY_KIND, fault_args

    where = tmp_path_factory.mktemp("every_kind")
    scenario = where / "s.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), 60.0))
    args = ["--set", "scenario.on_vehicle_loss=continue", *fault_args(EVERY_KIND)]
    runs: dict[str, Any] = {"scenario": scenario, "args": args}
    for engine in ("zenoh", "inprocess"):
        out = where / f"{engine}.mcap"
        runs[engine] = (
            out,
            cpf("run", str(scenario), "--engine", engine, *args, "--out", str(out), "--quiet", cwd=where),
        )
    return runs

"""Shared fixtures: the repository's scenario files, and shortened variants of them."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

from comms.bus import Publishers
from comms.messages import Message
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
    return RunMeta(**(base | fields))


# The slowest tests of a full run (make test prints them: --durations=30), 12-90 s each. Started first, so that the
# two xdist workers do not end with one of them running a long test alone while the other has nothing left.
SLOW_FIRST = (
    "test_extending_tutorial.py::test_the_tutorials_commands_run_and_the_engines_agree",
    "test_saturation.py::test_the_survey_that_diverges_unsaturated_stays_bounded_with_a_top_speed",
    "test_bit_identical.py::test_a_reference_run_records_what_it_recorded_before",
    "test_extensions.py::test_the_engines_record_the_same_with_an_extension",
    "test_navigation.py::test_the_report_draws_the_navigation_figure_only_for_a_run_with_navigation",
    "test_next_transmission.py::test_no_step_before_the_bound_transmits_and_the_bound_does",
    "test_extensions.py::test_a_law_by_import_path_runs_on_both_engines_with_its_options",
    "test_faults_e2e.py::test_an_unscheduled_death_is_noticed_and_survived_when_the_scenario_says_continue",
    "test_figures.py::test_eight_circles_with_a_kill_plot_eight_vehicles_against_the_mean",
    "test_cosim_e2e.py::test_same_seed_gives_identical_state_streams_over_a_lossy_channel",
    "test_inprocess.py::test_event_triggered_policy_matches_periodic_with_far_fewer_packets",
    "test_plant_mismatch.py::test_at_60_percent_mismatch_the_supervisor_keeps_the_tube",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The tests of SLOW_FIRST first (in that order), the rest as collected."""

    def rank(item: pytest.Item) -> int:
        name = item.nodeid.split("/")[-1]
        return next((i for i, prefix in enumerate(SLOW_FIRST) if name.startswith(prefix)), len(SLOW_FIRST))

    items.sort(key=rank)  # stable: the order within a rank is the collection's

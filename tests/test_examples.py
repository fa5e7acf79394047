"""The example scenarios of configs/examples/: valid, complete (every fault kind has one) and runnable.

Each runs shortened (the in-process engine, ~1 s each) and one on the Zenoh engine too, where its summary must be the
in-process one's.
"""

from __future__ import annotations

import typing
from pathlib import Path

import pytest

from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_schema import FaultSpec
from tests.conftest import CONFIGS
from tests.procs import cpf

pytestmark = pytest.mark.e2e
EXAMPLES = CONFIGS / "examples"
# Short runs for CI; long enough for each file's faults to start (a fault after the end of the run is an error).
SHORT = {
    "circles.toml": 30.0,
    "planar_paper.toml": 30.0,
    "lawnmower_survey.toml": 30.0,
    "per_link_comms.toml": 30.0,
    "every_fault.toml": 145.0,
    "micromodem_tdma.toml": 30.0,
    "helix_ring_30s.toml": 305.0,  # its fault starts at 300 s
}


def _fault_kinds() -> set[str]:
    union = typing.get_args(FaultSpec)[0]
    return {typing.get_args(model.model_fields["kind"].annotation)[0] for model in typing.get_args(union)}


def test_the_examples_are_the_ones_this_file_runs():
    assert sorted(p.name for p in EXAMPLES.glob("*.toml")) == sorted(SHORT)


def test_every_kind_of_fault_has_an_example():
    used = {fault.kind for path in EXAMPLES.glob("*.toml") for fault in load_scenario(path).faults}
    missing = _fault_kinds() - used
    assert not missing, f"no example in configs/examples/ uses the fault kinds {sorted(missing)}: add one"


def test_the_fault_kinds_are_found_by_introspection():
    assert {"speed_cap", "vehicle_kill", "clock_skew"} <= _fault_kinds() and len(_fault_kinds()) >= 11


@pytest.mark.parametrize("name", sorted(SHORT))
def test_an_example_says_where_its_schema_is_and_is_commented(name):
    lines = (EXAMPLES / name).read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("#:schema ")  # taplo / Even Better TOML: completion and checks in the editor
    assert (EXAMPLES / lines[0].removeprefix("#:schema ")).resolve().is_file()
    comments = [line for line in lines if "#" in line]
    assert len(comments) >= 10, "an example is a tutorial: say what each part does"


@pytest.mark.parametrize("name", sorted(SHORT))
def test_an_example_runs_shortened_in_process(tmp_path, name):
    done = _run(tmp_path, name, "inprocess")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "inprocess.mcap").stat().st_size > 0
    assert "path-following error after the transient" in done.stdout


def test_an_example_gives_the_same_summary_on_zenoh(tmp_path):
    runs = {engine: _run(tmp_path, "per_link_comms.toml", engine) for engine in ("zenoh", "inprocess")}
    for done in runs.values():
        assert done.returncode == 0, done.stderr
    zenoh, inprocess = (runs[e].stdout.splitlines()[1:] for e in ("zenoh", "inprocess"))  # line 0: engine, timing
    assert zenoh == inprocess and any(line.startswith("4->1") for line in zenoh)


def _run(tmp_path: Path, name: str, engine: str):
    duration = f"scenario.duration={SHORT[name]}"
    args = ("run", str(EXAMPLES / name), "--engine", engine, "--set", duration, "--out", f"{engine}.mcap", "--quiet")
    return cpf(*args, cwd=tmp_path)

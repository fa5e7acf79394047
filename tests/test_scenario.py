"""Tests for config.scenario: the valid configs, one-line errors naming file, field and value, the CLI's exit 2."""

from __future__ import annotations

import copy
import math
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from supervisor.config.scenario import load_scenario, parse_scenario, validate_data
from supervisor.config.scenario_schema import HelixPath, Scenario, SpeedCapFault
from supervisor.errors import ScenarioError

ROOT = Path(__file__).resolve().parent.parent
PAPER = (ROOT / "configs" / "paper.toml").read_text()
PAPER_DATA: dict[str, Any] = tomllib.loads(PAPER)
SOURCE = "bad.toml"
VEHICLE_2 = "[[vehicles]]\nid = 2\n"
FOURTH_VEHICLE = """
[[vehicles]]
id = 4
position = [0.0, 0.0, 0.0]
path = { type = "circle", radius = 10.0, period = 400.0 }
"""


def paper_with(old: str, new: str) -> str:
    """paper.toml with the first occurrence of old replaced; old must occur, so each case changes something."""
    assert old in PAPER, old
    return PAPER.replace(old, new, 1)


def error_of(text: str) -> str:
    """The first error (the usual one-line message); every error is one such line of the message."""
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, SOURCE)
    errors = info.value.errors
    assert str(info.value) == "\n".join(errors)
    for line in errors:
        assert_one_line(line)
    return errors[0]


def assert_one_line(message: str, source: str = SOURCE) -> None:
    assert len(message.splitlines()) == 1 and "\n" not in message, message
    assert message.startswith(f"{source}: "), message


def assert_names(message: str, field: str, value: str | None) -> None:
    """One line: '<file>: <field>: <problem>[, got <value>]'."""
    assert_one_line(message)
    assert message.startswith(f"{SOURCE}: {field}: "), message
    if value is not None:
        assert value in message.removeprefix(f"{SOURCE}: {field}: "), message


# --- the valid configs ------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["paper.toml", "inline5.toml"])
def test_the_repository_configs_are_valid(name: str) -> None:
    scenario = load_scenario(ROOT / "configs" / name)
    assert scenario.scenario.name == name.removesuffix(".toml")
    assert parse_scenario((ROOT / "configs" / name).read_text()) == scenario


def test_paper_toml_holds_the_papers_values() -> None:
    sc = parse_scenario(PAPER, "paper.toml")
    assert (sc.scenario.duration, sc.scenario.step, sc.scenario.dimension) == (400.0, 0.1, 3)
    assert sc.vehicle_ids == [1, 2, 3]
    assert sc.graph.edges == ((1, 2), (1, 3))
    assert sc.neighbours(1) == [2, 3] and sc.neighbours(2) == [1] and sc.neighbours(3) == [1]
    assert [v.position for v in sc.vehicles] == [(10.0, -15.0, -5.0), (5.0, 0.0, 0.0), (20.0, -25.0, 5.0)]
    paths = [v.path for v in sc.vehicles]
    assert all(isinstance(p, HelixPath) for p in paths)
    helices = [p for p in paths if isinstance(p, HelixPath)]
    assert [p.radius for p in helices] == [20.0, 15.0, 25.0]
    for p in helices:
        assert (p.climb, p.period, p.center) == (0.05, 400.0, (0.0, 0.0, 0.0))
        assert p.phase_rad == pytest.approx(-3.0 * math.pi / 4.0, abs=1e-15)
    assert sc.faults == (SpeedCapFault(kind="speed_cap", vehicle=1, start=150.0, end=250.0, gamma_dot_max=0.5),)
    assert sc.path_following.delta == -1.0 and sc.coordination.law == "corrected"


def test_validate_data_is_what_parse_scenario_uses() -> None:
    assert validate_data(copy.deepcopy(PAPER_DATA), "paper.toml") == parse_scenario(PAPER, "paper.toml")


# --- bad files: (TOML text, field, the bad value as the message shows it) ---------------------------------

BAD: dict[str, tuple[str, str, str | None]] = {
    # missing required fields
    "no duration": (paper_with("duration = 400.0\n", ""), "scenario.duration", None),
    "no graph": (paper_with("[graph]\nedges = [[1, 2], [1, 3]]\n", ""), "graph", None),
    "no position": (paper_with("position = [5.0, 0.0, 0.0]\n", ""), "vehicles[1].position", None),
    "no path type": (paper_with('type = "helix", ', ""), "vehicles[0].path.type", None),
    # wrong types
    "duration a word": (paper_with("duration = 400.0", 'duration = "long"'), "scenario.duration", "'long'"),
    "duration a numeric string": (paper_with("duration = 400.0", 'duration = "400"'), "scenario.duration", "'400'"),
    "duration a boolean": (paper_with("duration = 400.0", "duration = true"), "scenario.duration", "True"),
    "position a string": (
        paper_with("position = [10.0, -15.0, -5.0]", 'position = "here"'),
        "vehicles[0].position",
        "'here'",
    ),
    "position of 2": (
        paper_with("position = [5.0, 0.0, 0.0]", "position = [5.0, 0.0]"),
        "vehicles[1].position",
        "[5.0, 0.0]",
    ),
    "position of 4": (
        paper_with("position = [5.0, 0.0, 0.0]", "position = [5.0, 0.0, 0.0, 1.0]"),
        "vehicles[1].position",
        "[5.0, 0.0, 0.0, 1.0]",
    ),
    "edges a number": (paper_with("edges = [[1, 2], [1, 3]]", "edges = 3"), "graph.edges", "got 3"),
    "id a float": (paper_with("id = 3", "id = 3.0"), "vehicles[2].id", "3.0"),
    "vehicles a table": (PAPER.split("[[vehicles]]")[0] + "[vehicles]\nid = 1\n", "vehicles", "a table"),
    "scenario not a table": ("scenario = 3\n[vehicle]\n" + PAPER.split("[vehicle]\n")[1], "scenario", "got 3"),
    "one vehicle": (PAPER.split(VEHICLE_2)[0], "vehicles", "at least 2 items"),
    # graphs
    "disconnected 4": (
        paper_with("edges = [[1, 2], [1, 3]]", "edges = [[1, 2], [3, 4]]") + FOURTH_VEHICLE,
        "graph.edges",
        "[[1, 2], [3, 4]]",
    ),
    "disconnected 3": (paper_with("edges = [[1, 2], [1, 3]]", "edges = [[1, 2]]"), "graph.edges", "[[1, 2]]"),
    "edge to no vehicle": (paper_with("edges = [[1, 2], [1, 3]]", "edges = [[1, 2], [1, 7]]"), "graph.edges[1]", "7"),
    "self loop": (paper_with("edges = [[1, 2], [1, 3]]", "edges = [[1, 2], [3, 3]]"), "graph.edges[1]", "[3, 3]"),
    "duplicate id": (paper_with("id = 3", "id = 2"), "vehicles[2].id", "got 2"),
    "id zero": (paper_with("id = 1\n", "id = 0\n"), "vehicles[0].id", "got 0"),
    # paths
    "spiral": (paper_with('type = "helix"', 'type = "spiral"'), "vehicles[0].path.type", "'spiral'"),
    "negative radius": (paper_with("radius = 15.0", "radius = -15.0"), "vehicles[1].path.radius", "-15.0"),
    "zero period": (paper_with("period = 400.0", "period = 0.0"), "vehicles[0].path.period", "0.0"),
    "tiny period": (paper_with("period = 400.0", "period = 5e-324"), "vehicles[0].path.period", "5e-324"),
    "infinite phase": (
        paper_with("phase_rad = -2.356194490192345", "phase_rad = -inf"),
        "vehicles[0].path.phase_rad",
        "-inf",
    ),
    "nan climb": (paper_with("climb = 0.05", "climb = nan"), "vehicles[0].path.climb", "nan"),
    "extra path key": (paper_with("climb = 0.05", "climb = 0.05, pitch = 2.0"), "vehicles[0].path.pitch", None),
    "lawnmower of too many legs": (
        paper_with(
            'path = { type = "helix", radius = 15.0, climb = 0.05, period = 400.0, phase_rad = -2.356194490192345 }',
            'path = { type = "lawnmower", origin = [0, 0, 0], leg_length = 50, spacing = 5, legs = 2147483648 }',
        ),
        "vehicles[1].path.legs",
        "2147483648",
    ),
    "line not moving": (
        paper_with(
            'path = { type = "helix", radius = 25.0, climb = 0.05, period = 400.0, phase_rad = -2.356194490192345 }',
            'path = { type = "line", start = [0.0, 0.0, 0.0], velocity = [0.0, 0.0, 0.0] }',
        ),
        "vehicles[2].path.velocity",
        "0.0",
    ),
    # numbers of the run
    "negative step": (paper_with("step = 0.1", "step = -0.1"), "scenario.step", "-0.1"),
    "zero duration": (paper_with("duration = 400.0", "duration = 0.0"), "scenario.duration", "got 0.0"),
    "infinite duration": (paper_with("duration = 400.0", "duration = inf"), "scenario.duration", "inf"),
    "nan step": (paper_with("step = 0.1", "step = nan"), "scenario.step", "nan"),
    "step above duration": (paper_with("step = 0.1", "step = 500.0"), "scenario.step", "500.0"),
    "dimension 4": (paper_with("dimension = 3", "dimension = 4"), "scenario.dimension", "got 4"),
    # keys and names
    "typo": (paper_with("duration = 400.0", "durration = 400.0"), "scenario.durration", None),
    "unknown section": (PAPER + "\n[simulation]\nfoo = 1\n", "simulation", None),
    "key with a line break": (paper_with("duration = 400.0", '"dur\\nation" = 400.0'), "scenario['dur\\nation']", None),
    "unknown preset": (paper_with('preset = "remus100_neutral"', 'preset = "sirene"'), "vehicle.preset", "'sirene'"),
    "unknown law": (paper_with('law = "corrected"', 'law = "eq5"'), "coordination.law", "'eq5'"),
    "delta zero": (paper_with("delta = -1.0", "delta = 0.0"), "path_following.delta", "0.0"),
    "negative gain": (paper_with("k1 = 0.5", "k1 = -0.5"), "path_following.k1", "-0.5"),
    # vehicle overrides
    "unknown override": (
        paper_with('preset = "remus100_neutral"', 'preset = "remus100_neutral"\noverrides = { masss = 40.0 }'),
        "vehicle.overrides.masss",
        None,
    ),
    "override a vector of the wrong length": (  # mass: one number (the rigid body's) or M's diagonal
        paper_with('preset = "remus100_neutral"', 'preset = "remus100_neutral"\noverrides = { mass = [40.0, 41.0] }'),
        "vehicle.overrides.mass",
        "[40.0, 41.0]",
    ),
    "override a vector for a number": (
        paper_with(
            'preset = "remus100_neutral"', 'preset = "remus100_neutral"\noverrides = { weight = [1.0, 2.0, 3.0] }'
        ),
        "vehicle.overrides.weight",
        "[1.0, 2.0, 3.0]",
    ),
    "override a string": (
        paper_with('preset = "remus100_neutral"', 'preset = "remus100_neutral"\noverrides = { max_torque = "20" }'),
        "vehicle.overrides.max_torque",
        "'20'",
    ),
    "overrides not a table": (
        paper_with('preset = "remus100_neutral"', 'preset = "remus100_neutral"\noverrides = [1.0]'),
        "vehicle.overrides",
        "[1.0]",
    ),
    "gamma0 a word": (paper_with(VEHICLE_2, VEHICLE_2 + 'gamma0 = "start"\n'), "vehicles[1].gamma0", "'start'"),
    # faults
    "fault on no vehicle": (paper_with("vehicle = 1\n", "vehicle = 9\n"), "faults[0].vehicle", "9"),
    "fault ends before it starts": (paper_with("end = 250.0", "end = 100.0"), "faults[0].end", "100.0"),
    "fault ends as it starts": (paper_with("end = 250.0", "end = 150.0"), "faults[0].end", "150.0"),
    "unknown fault kind": (paper_with('kind = "speed_cap"', 'kind = "stop"'), "faults[0].kind", "'stop'"),
}


@pytest.mark.parametrize(("text", "field", "value"), list(BAD.values()), ids=list(BAD))
def test_a_bad_scenario_is_one_line_naming_file_field_and_value(text: str, field: str, value: str | None) -> None:
    assert_names(error_of(text), field, value)


def test_a_misspelt_key_is_reported_before_the_missing_one() -> None:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(paper_with("duration = 400.0", "durration = 400.0"), SOURCE)
    first, second = info.value.errors
    assert first == f"{SOURCE}: scenario.durration: unknown key"
    assert second == f"{SOURCE}: scenario.duration: missing required field"


def test_invalid_toml_names_the_file_and_the_line() -> None:
    message = error_of(paper_with("duration = 400.0", "duration = = 400.0"))
    assert_one_line(message)
    assert "invalid TOML" in message and "line 10" in message


def test_load_scenario_names_the_path(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(paper_with("step = 0.1", "step = -0.1"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(bad)
    assert str(info.value) == f"{bad}: scenario.step: must be greater than or equal to 0.001, got -0.1"


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("missing.toml", None, "No such file or directory"),
        ("latin1.toml", b'[scenario]\nname = "caf\xe9"\n', "not UTF-8"),
    ],
)
def test_an_unreadable_file_is_a_scenario_error(tmp_path: Path, name: str, content: bytes | None, problem: str) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert_one_line(str(info.value), str(path))
    assert problem in str(info.value)


def test_a_file_that_begins_with_a_byte_order_mark_reads_as_without(tmp_path: Path) -> None:
    """Some editors write UTF-8 with a byte-order mark; TOML's parser took it for an 'invalid statement (at line 1,
    column 1)' (found by a new user)."""
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + PAPER.encode())
    assert load_scenario(path) == load_scenario(ROOT / "configs" / "paper.toml")


def test_a_directory_is_a_scenario_error(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="cannot read scenario file"):
        load_scenario(tmp_path)


def test_a_source_with_a_line_break_still_gives_one_line() -> None:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(paper_with("step = 0.1", "step = -0.1"), "odd\nname.toml")
    assert str(info.value) == "odd\\nname.toml: scenario.step: must be greater than or equal to 0.001, got -0.1"


def test_a_long_bad_value_is_shortened() -> None:
    message = error_of(paper_with('name = "paper"', f"name = [{', '.join(['1'] * 200)}]"))
    assert_names(message, "scenario.name", "[1, 1, 1")
    assert len(message) < 200 and message.endswith("...")


# --- the command line -------------------------------------------------------------------------------------

E2E: dict[str, tuple[str, str, str]] = {
    "negative step": (paper_with("step = 0.1", "step = -0.1"), "scenario.step", "-0.1"),
    "spiral": (paper_with('type = "helix"', 'type = "spiral"'), "vehicles[0].path.type", "'spiral'"),
    "disconnected": (paper_with("edges = [[1, 2], [1, 3]]", "edges = [[1, 2]]"), "graph.edges", "[[1, 2]]"),
    "infinite phase": (
        paper_with("phase_rad = -2.356194490192345", "phase_rad = inf"),
        "vehicles[0].path.phase_rad",
        "inf",
    ),
}


@pytest.mark.e2e
@pytest.mark.parametrize(("text", "field", "value"), list(E2E.values()), ids=list(E2E))
def test_cpf_run_exits_2_with_one_line(tmp_path: Path, text: str, field: str, value: str) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    out = tmp_path / "x.mcap"
    command = [sys.executable, "-m", "supervisor.cli", "run", str(bad), "--out", str(out), "--quiet"]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stdout == ""
    assert done.stderr.endswith("\n") and len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith(f"cpf: error: {bad}: {field}: "), done.stderr
    assert value in done.stderr
    assert not out.exists()


@pytest.mark.e2e
def test_cpf_run_of_a_missing_file_exits_2(tmp_path: Path) -> None:
    cpf = Path(sys.executable).parent / "cpf"
    missing, out = tmp_path / "nope.toml", tmp_path / "x.mcap"
    done = subprocess.run(
        [str(cpf), "run", str(missing), "--out", str(out)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2
    assert done.stderr == f"cpf: error: {missing}: cannot read scenario file: No such file or directory\n"
    assert not out.exists()


# --- property: any damage to paper.toml's data is a valid scenario or a one-line ScenarioError ------------

Node = dict[str, Any] | list[Any]
_SCALARS = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8)
VALUES = st.recursive(
    _SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=8,
)


def _locations(node: Any, prefix: tuple[str | int, ...] = ()) -> list[tuple[str | int, ...]]:
    """Every key or index under node, at any depth."""
    items: list[tuple[str | int, Any]] = []
    if isinstance(node, dict):
        items = list(node.items())
    elif isinstance(node, list):
        items = list(enumerate(node))
    out: list[tuple[str | int, ...]] = []
    for key, child in items:
        out += [(*prefix, key), *_locations(child, (*prefix, key))]
    return out


def _mutate(doc: dict[str, Any], data: st.DataObject) -> None:
    """Delete one key or list item of doc, or replace it by a value of another type."""
    location = data.draw(st.sampled_from(_locations(doc)))
    parent: Any = doc
    for key in location[:-1]:
        parent = parent[key]
    key = location[-1]
    if data.draw(st.booleans()):
        del parent[key]
    else:
        old = parent[key]
        parent[key] = data.draw(VALUES.filter(lambda value: type(value) is not type(old)))


@settings(max_examples=300, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_damaged_data_is_valid_or_a_one_line_scenario_error(data: st.DataObject) -> None:
    doc = copy.deepcopy(PAPER_DATA)
    for _ in range(data.draw(st.integers(1, 3))):
        if _locations(doc):
            _mutate(doc, data)
    try:
        scenario = validate_data(doc, SOURCE)
    except ScenarioError as exc:
        assert str(exc) == "\n".join(exc.errors)
        for message in exc.errors:
            assert_one_line(message)
            assert len(message) > len(f"{SOURCE}: ") + 3
    else:
        assert isinstance(scenario, Scenario)

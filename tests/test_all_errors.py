"""Validation shows every error in a file at once: pydantic's and the cross-field rules', one line each
('<file>: <field>: <problem>, got <value>'), the first being the usual one-line message."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest

from supervisor.config.scenario import load_scenario, parse_scenario, scenario_errors, validate_data
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS
from tests.procs import cpf

PAPER = (CONFIGS / "paper.toml").read_text()
PAPER_DATA = tomllib.loads(PAPER)
SOURCE = "bad.toml"


def broken(**changes: object) -> dict:
    """The paper's scenario as parsed TOML, with dotted keys set (vehicles.0.id: list items by index)."""
    data = copy.deepcopy(PAPER_DATA)
    for dotted, value in changes.items():
        node = data
        *parents, last = dotted.split("__")
        for part in parents:
            node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value
    return data


def test_every_error_of_a_file_is_reported_pydantic_and_cross_field_alike() -> None:
    data = broken(
        comms__loss=1.5,
        graph__edges=[[1, 2], [1, 5]],  # cross-field: vehicle 5 does not exist
        vehicle__overrides={"weight": [1.0, 2.0, 3.0]},  # cross-field: the weight is a number
    )
    data["scenario"]["durration"] = data["scenario"].pop("duration")  # misspelt: also makes duration missing
    errors = scenario_errors(data, SOURCE)
    assert errors == [
        f"{SOURCE}: scenario.durration: unknown key",
        f"{SOURCE}: scenario.duration: missing required field",
        f"{SOURCE}: comms.loss: must be less than or equal to 1, got 1.5",
        f"{SOURCE}: graph.edges[1]: vehicle 5 is not in [[vehicles]] ids [1, 2, 3], got [1, 5]",
        f"{SOURCE}: vehicle.overrides.weight: must be a number, got [1.0, 2.0, 3.0]",
    ]
    with pytest.raises(ScenarioError) as info:
        validate_data(data, SOURCE)
    assert info.value.errors == errors
    assert str(info.value) == "\n".join(errors)  # the first line is the usual one-line message


def test_cross_field_errors_of_valid_sections_are_all_reported() -> None:
    data = broken(
        scenario__step=0.3,  # does not divide 400
        graph__edges=[[1, 1], [1, 2]],  # a self loop, and vehicle 3 is unreachable
        vehicles__1__id=1,  # duplicate
    )
    assert scenario_errors(data, SOURCE) == [
        f"{SOURCE}: vehicles[1].id: duplicate vehicle id, got 1",
        f"{SOURCE}: scenario.step: must divide duration (400.0) into whole steps (1333.33 of them), got 0.3",
        f"{SOURCE}: graph.edges[0]: an edge must join two vehicles, got [1, 1]",
        f"{SOURCE}: graph.edges[1]: vehicle 2 is not in [[vehicles]] ids [1, 1, 3], got [1, 2]",
    ]  # (the faults' rule and the comms rule still ran: nothing to say there)


def test_a_rule_that_reads_a_section_pydantic_rejected_is_skipped_not_crashed_or_misled() -> None:
    """vehicles[0] is rejected: the graph rule would otherwise say vehicle 1 is not in [[vehicles]]."""
    data = broken(vehicles__0={"id": 1, "position": [0.0, 0.0]})  # position too short, path missing
    errors = scenario_errors(data, SOURCE)
    assert errors == [
        f"{SOURCE}: vehicles[0].position: too few items, got [0.0, 0.0]",
        f"{SOURCE}: vehicles[0].path: missing required field",
    ]  # and not "vehicles: must have at least 2 items" for the one left, nor any graph error


def test_a_union_field_is_one_line() -> None:
    errors = scenario_errors(broken(vehicles__1__gamma0="start"), SOURCE)
    assert errors == [f"{SOURCE}: vehicles[1].gamma0: must be a valid number or 'closest', got 'start'"]


def test_a_valid_scenario_has_no_errors() -> None:
    assert scenario_errors(copy.deepcopy(PAPER_DATA), SOURCE) == []
    assert validate_data(copy.deepcopy(PAPER_DATA), SOURCE) == parse_scenario(PAPER, SOURCE)


def test_load_scenario_carries_the_list(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(PAPER.replace("step = 0.1", "step = 0.3").replace("k = 0.2", "k = -0.2"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(bad)
    assert info.value.errors == [
        f"{bad}: coordination.k: must be greater than 0, got -0.2",
        f"{bad}: scenario.step: must divide duration (400.0) into whole steps (1333.33 of them), got 0.3",
    ]


def test_cpf_run_prints_every_error_and_starts_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(PAPER.replace("step = 0.1", "step = 0.3").replace("k = 0.2", "k = -0.2"))
    done = cpf("run", str(bad), "--out", "never.mcap", "--quiet", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        f"cpf: error: {bad}: coordination.k: must be greater than 0, got -0.2",
        f"cpf: error: {bad}: scenario.step: must divide duration (400.0) into whole steps (1333.33 of them), got 0.3",
    ]
    assert not (tmp_path / "never.mcap").exists()


def test_a_thousand_errors_print_the_first_twenty_and_a_count(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A fleet of 10,000 vehicles printed 29,234 error lines (issue 31): the first SHOWN_ERRORS, then how many more."""
    from supervisor.cli import main
    from supervisor.errors import SHOWN_ERRORS

    vehicles = "".join(  # each vehicle 1 Tm deep, and its path too: two errors each (its id was a third, when ids
        # stopped at 255)
        f"[[vehicles]]\nid = {i}\nposition = [0.0, {i}.0, -1e12]\n"
        f'path = {{ type = "line", start = [0.0, {i}.0, -1e12], velocity = [1.0, 0.0, 0.0] }}\n'
        for i in range(1, 601)
    )
    edges = ", ".join(f"[{i}, {i + 1}]" for i in range(1, 600))
    path = tmp_path / "fleet.toml"
    path.write_text(f'[scenario]\nname = "fleet"\nduration = 1.0\nstep = 0.1\n[graph]\nedges = [{edges}]\n{vehicles}')
    with pytest.raises(ScenarioError) as refused:
        load_scenario(path)
    found = len(refused.value.errors)
    assert found > 600 and len(str(refused.value).splitlines()) == SHOWN_ERRORS + 1
    assert main(["run", str(path), "--engine", "inprocess", "--out", str(tmp_path / "r.mcap")]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert (
        len(lines) == SHOWN_ERRORS + 1
        and lines[-1] == f"cpf: error: ... and {found - SHOWN_ERRORS} more ({found} errors in all)"
    )

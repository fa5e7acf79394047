"""The scenario reference and the JSON Schema: generated from the schema, committed in step with it, complete."""

from __future__ import annotations

import json
import tomllib
import typing
from collections.abc import Iterator

import jsonschema
import pytest
from pydantic import BaseModel

from supervisor.config.reference import json_schema, markdown, schema_text
from supervisor.config.scenario_schema import FaultSpec, PathSpec, Scenario
from tests.conftest import CONFIGS, ROOT

DOCS = ROOT / "docs"
REGENERATE = "regenerate it with `make docs` (cpf schema --markdown > docs/scenario-reference.md; cpf schema > " \
    "docs/scenario.schema.json) and commit it"  # fmt: skip
SCENARIOS = sorted(CONFIGS.glob("*.toml")) + sorted((CONFIGS / "examples").glob("*.toml"))


def _models(model: type[BaseModel]) -> Iterator[type[BaseModel]]:
    """model and every model reachable through its fields' annotations."""
    yield model
    for info in model.model_fields.values():
        for inner in _classes(info.annotation):
            yield from _models(inner)


def _classes(annotation: object) -> Iterator[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        yield annotation
    for arg in typing.get_args(annotation):
        yield from _classes(arg)


def _variants(union: object) -> list[type[BaseModel]]:
    return list(_classes(union))


def test_the_committed_reference_is_the_generated_one():
    committed = (DOCS / "scenario-reference.md").read_text(encoding="utf-8")
    assert committed == markdown(), f"docs/scenario-reference.md is out of date with the schema: {REGENERATE}"


def test_the_committed_json_schema_is_the_generated_one():
    committed = (DOCS / "scenario.schema.json").read_text(encoding="utf-8")
    assert committed == schema_text(), f"docs/scenario.schema.json is out of date with the schema: {REGENERATE}"


def test_every_field_of_every_section_has_a_description_or_its_table_one():
    missing = []
    for model in set(_models(Scenario)):
        if not (model.__doc__ or "").strip() or "A base class" in (model.__doc__ or ""):
            missing.append(f"{model.__name__} (docstring)")
        for name, info in model.model_fields.items():
            is_table = any(True for _ in _classes(info.annotation)) and not info.description
            if not info.description and name not in ("kind", "type") and not is_table:
                missing.append(f"{model.__name__}.{name}")
    assert not missing, f"fields without a description (Field(description=...)): {sorted(missing)}"


def test_the_reference_has_a_row_for_every_field_and_a_section_for_every_path_and_fault():
    text = markdown()
    for model in set(_models(Scenario)):
        for name in model.model_fields:
            if name not in ("kind", "type"):
                assert f"| `{name}` |" in text, f"{model.__name__}.{name} missing from the reference"
    for path in _variants(PathSpec):
        kind = path.model_fields["type"].annotation.__args__[0]  # type: ignore[union-attr]
        assert f'## `[vehicles.path] type = "{kind}"`' in text
    for fault in _variants(FaultSpec):
        kind = fault.model_fields["kind"].annotation.__args__[0]  # type: ignore[union-attr]
        assert f'## `[[faults]] kind = "{kind}"`' in text


def test_the_reference_says_what_gamma_is_for_every_path_type_and_how_closest_is_found():
    text = markdown()
    gamma_section = text.split("**What gamma is.**")[1].split("## Tables")[0]
    for path in _variants(PathSpec):
        kind = path.model_fields["type"].annotation.__args__[0]  # type: ignore[union-attr]
        line = next(line for line in gamma_section.splitlines() if line.startswith(f'- `type = "{kind}"`'))
        assert "gamma" in line.split(":", 1)[1]
    # As supervisor.config.fleet.initial_gamma searches: around the first vehicle's gamma0, not around 0.
    assert "on a circle or helix within half a period of the first [[vehicles]]'s gamma0" in text


def test_the_reference_gives_bounds_defaults_and_choices():
    text = markdown()
    assert "| `step` | number | *required* | >= 0.001; <= 4294967.295 | integration and sync step, s" in text
    assert "| `velocity` | [number, number, number] | [0.0, 0.0, 0.0] | each >= -5.0; <= 5.0 |" in text
    assert "| `dimension` | integer | 3 | 2, 3 |" in text
    assert "| `loss` | number | 0.0 | >= 0; <= 1 |" in text
    assert '"whoi_micromodem_rate0"' in text  # the modem presets, as allowed values


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: str(p.relative_to(CONFIGS)))
def test_every_shipped_scenario_is_valid_against_the_json_schema(path):
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator(json_schema()).validate(data)


@pytest.mark.parametrize(
    ("change", "where"),
    [
        (lambda d: d["scenario"].update(step="0.1"), "step"),  # a string is not a number
        (lambda d: d["scenario"].update(dimension=4), "dimension"),
        (lambda d: d["comms"].update(modem="acme"), "modem"),
        (lambda d: d["faults"][0].update(kind="meteor"), "faults"),
        (lambda d: d["vehicles"][0].update(colour="red"), "colour"),
        (lambda d: d["vehicles"][0]["path"].pop("radius"), "radius"),
    ],
)
def test_the_json_schema_refuses_what_the_loader_refuses(change, where):
    data = tomllib.loads((CONFIGS / "paper_acoustic.toml").read_text(encoding="utf-8"))
    change(data)
    errors = list(jsonschema.Draft202012Validator(json_schema()).iter_errors(data))
    assert errors and where in " ".join(_texts(errors))


def _texts(errors: list[jsonschema.ValidationError]) -> Iterator[str]:
    """Every error's location and message, and those of the branches of a oneOf/anyOf that failed."""
    for error in errors:
        yield json.dumps(list(error.absolute_path)) + error.message
        yield from _texts(list(error.context or []))


def test_the_json_schema_is_toml_shaped():
    schema = json_schema()
    assert ": null" not in json.dumps(schema) and '"null"' not in json.dumps(schema)  # TOML has no null
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["required"] == ["scenario", "graph", "vehicles"]

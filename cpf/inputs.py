"""What the Python API is given, as the command line would be given it: a scenario file, --set KEY=VALUE, --fault
SPEC and --param KEY=VALUES texts. A scenario given as TOML text or as a dict is written to a file (the engines, the
log's meta and `cpf vehicle` started by hand all read one); values become TOML, as the command line's are read."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeAlias

from supervisor.config.toml_writer import toml_assignment, toml_key, toml_value
from supervisor.errors import ScenarioError

Scenario: TypeAlias = "str | Path | Mapping[str, Any]"
Changes: TypeAlias = "Mapping[str, Any] | Sequence[str] | None"
SCENARIO_FILE = "scenario.toml"  # a scenario given as text or dict, in the run's temporary directory


def scenario_file(scenario: Scenario, where: Path) -> Path:
    """The scenario as a file: a path as is; TOML text (a str with a line break) or a dict written to
    where/scenario.toml. ScenarioError for a dict value TOML cannot hold."""
    if isinstance(scenario, Mapping):
        text = toml_text(scenario)
    elif isinstance(scenario, str) and "\n" in scenario:
        text = scenario
    else:
        return Path(scenario)
    path = where / SCENARIO_FILE
    path.write_text(text, encoding="utf-8")
    return path


def toml_text(data: Mapping[str, Any]) -> str:
    """A scenario dict as TOML: its values, then a [table] per dict and a [[table]] per list of dicts."""
    lines = [toml_assignment(k, v) for k, v in data.items() if not _table(v) and not _tables(v)]
    for key, value in data.items():
        if _table(value):
            lines += ["", f"[{toml_key(key)}]", *(toml_assignment(k, v) for k, v in value.items())]
        elif _tables(value):
            for item in value:
                lines += ["", f"[[{toml_key(key)}]]", *(toml_assignment(k, v) for k, v in item.items())]
    return "\n".join(lines) + "\n"


def _table(value: Any) -> bool:
    return isinstance(value, Mapping)


def _tables(value: Any) -> bool:
    return isinstance(value, list | tuple) and bool(value) and all(isinstance(v, Mapping) for v in value)


def overrides(given: Changes) -> list[str]:
    """--set texts: KEY=VALUE strings as they are, a dict's items with their values as TOML."""
    if given is None:
        return []
    if isinstance(given, Mapping):
        return [f"{key}={toml_value(value)}" for key, value in given.items()]
    return _texts(given, "set")


def fault_specs(given: Sequence[str | Mapping[str, Any]] | None) -> list[str]:
    """--fault texts: specs as they are, a dict as KEY=VALUE,... with its values as TOML."""
    return [spec if isinstance(spec, str) else ",".join(toml_assignment(k, v) for k, v in spec.items())
            for spec in given or ()]  # fmt: skip


def param_specs(params: Mapping[str, Any]) -> list[str]:
    """--param texts: KEY=v1,v2,... from a list of values, KEY=TEXT from a str (e.g. '0:0.8:0.1', as the CLI)."""
    return [f"{key}={values}" if isinstance(values, str) else f"{key}={','.join(toml_value(v) for v in values)}"
            for key, values in params.items()]  # fmt: skip


def _texts(given: Sequence[str], what: str) -> list[str]:
    if isinstance(given, str) or not all(isinstance(text, str) for text in given):
        raise ScenarioError(f"{what}: a dict of KEY: VALUE or a list of 'KEY=VALUE' strings, got {given!r}")
    return list(given)


# cpf.run's own arguments, and what would print instead of running: not to be given again in options
OWN_OPTIONS = {"--engine": "engine=", "--out": "out=", "--seed": "seed=", "--set": "set=", "--fault": "faults=",
               "--quiet": "progress=False", "--help": "help(cpf.run)", "-h": "help(cpf.run)"}  # fmt: skip


def run_options(options: Sequence[str]) -> list[str]:
    """options as cpf.run hands them on; ScenarioError for one of its own arguments given again there (which one won
    depended on the option: --engine the option's, --seed the argument's, --out the option's with a Run of the
    other log) or --help (it printed and raised SystemExit)."""
    if isinstance(options, str) or not all(isinstance(text, str) for text in options):
        raise ScenarioError(f"options: a list of cpf run's options as strings (['--no-foxglove']), got {options!r}")
    texts = list(options)
    for text in texts:
        name = text.partition("=")[0]
        # as argparse reads it: a long option's unambiguous start (--eng) is the option
        own = [o for o in OWN_OPTIONS if o == name or (name.startswith("--") and len(name) > 2 and o.startswith(name))]
        if own:
            raise ScenarioError(f"options: {own[0]} is cpf.run's own ({OWN_OPTIONS[own[0]]}), got {text!r}")
    return texts

"""What the Python API is given, as the command line would be given it: a scenario file, --set KEY=VALUE, --fault
SPEC and --param KEY=VALUES texts. A scenario given as TOML text or as a dict is written to a file (the engines, the
log's meta and `cpf vehicle` started by hand all read one); values become TOML, as the command line's are read."""

from __future__ import annotations

import numbers
import os
from collections.abc import Iterable, Mapping, Sequence
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
        return path_of(scenario, "scenario", ", TOML text (a str with a line break) or a dict of the file's tables")
    path = where / SCENARIO_FILE
    path.write_text(text, encoding="utf-8")
    return path


def path_of(given: Any, what: str, also: str = "", error: type[ScenarioError] = ScenarioError) -> Path:
    """given as a Path: a str (not '', which is no file: the current directory) or a Path; error '<what>: a path
    (str or Path)<also>, got <given>' for anything else (bytes, a number, None)."""
    if isinstance(given, os.PathLike) or (isinstance(given, str) and given):
        return Path(given)
    raise error(f"{what}: a path (str or Path){also}, got {given!r}")


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
    return _listed(given, "set", "a dict of KEY: VALUE or a list of 'KEY=VALUE' strings")


def fault_specs(given: Sequence[str | Mapping[str, Any]] | None) -> list[str]:
    """--fault texts: specs as they are, a dict as KEY=VALUE,... with its values as TOML."""
    kinds = "a list of --fault specs ('kind=blackout,start=5') or dicts ({'kind': 'blackout', 'start': 5})"
    specs = _listed([] if given is None else given, "faults", kinds, (str, Mapping))
    return [spec if isinstance(spec, str) else ",".join(toml_assignment(k, v) for k, v in spec.items())
            for spec in specs]  # fmt: skip


def param_specs(params: Mapping[str, Any]) -> list[str]:
    """--param texts: KEY=TEXT from a str (e.g. '0:0.8:0.1', as the CLI), KEY=v1,v2,... from a list (a tuple, an
    array) of values, KEY=v from one value (a number, a bool, a dict: a table)."""
    if not isinstance(params, Mapping):
        raise ScenarioError(f"params: a dict of KEY: values ({{'comms.loss': [0.1, 0.2]}}, or '0:0.8:0.1' as --param "
                            f"takes it), got {params!r}")  # fmt: skip
    return [f"{key}={_swept(key, values)}" for key, values in params.items()]


def _swept(key: str, values: Any) -> str:
    """One param's values as --param takes them; ScenarioError for what is neither a value nor values (None)."""
    if isinstance(values, str):
        return values
    if getattr(values, "ndim", None) == 0:  # a 0-d numpy array: its value
        values = values.item()
    if isinstance(values, numbers.Number | Mapping):  # bool too
        values = [values]
    elif not isinstance(values, Iterable):
        raise ScenarioError(f"params: {key}: a value, a list of values or a --param text ('0:0.8:0.1'), got {values!r}")
    return ",".join(toml_value(v) for v in values)


def _listed(given: Any, what: str, expected: str, kinds: type | tuple[type, ...] = str) -> list[Any]:
    """given as a list, each of its items one of kinds; ScenarioError '<what>: <expected>, got <given>' otherwise
    (a str is not a list of its characters, nor a dict one of its keys)."""
    if (
        isinstance(given, str | bytes)
        or not isinstance(given, Sequence)
        or not all(isinstance(x, kinds) for x in given)
    ):
        raise ScenarioError(f"{what}: {expected}, got {given!r}")
    return list(given)


# cpf.run's own arguments, and what would print instead of running: not to be given again in options
OWN_OPTIONS = {"--engine": "engine=", "--out": "out=", "--seed": "seed=", "--set": "set=", "--fault": "faults=",
               "--quiet": "progress=False", "--help": "help(cpf.run)", "-h": "help(cpf.run)"}  # fmt: skip


def run_options(options: Sequence[str]) -> list[str]:
    """options as cpf.run hands them on; ScenarioError for one of its own arguments given again there (which one won
    depended on the option: --engine the option's, --seed the argument's, --out the option's with a Run of the
    other log) or --help (it printed and raised SystemExit)."""
    texts = _listed(options, "options", "a list of cpf run's options as strings (['--no-foxglove'])")
    for text in texts:
        name = text.partition("=")[0]
        # as argparse reads it: a long option's unambiguous start (--eng) is the option
        own = [o for o in OWN_OPTIONS if o == name or (name.startswith("--") and len(name) > 2 and o.startswith(name))]
        if own:
            raise ScenarioError(f"options: {own[0]} is cpf.run's own ({OWN_OPTIONS[own[0]]}), got {text!r}")
    return texts

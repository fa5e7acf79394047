"""Scenario files: TOML parsed into typed, frozen objects and validated completely before anything starts.

Every error names the file, the field and the bad value on one line, e.g.
    configs/bad.toml: scenario.step: must be greater than or equal to 0.001, got -0.1
See configs/paper.toml for a documented example of every section.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

from pydantic import TypeAdapter, ValidationError
from pydantic_core import ErrorDetails

from supervisor.config.scenario_checks import cross_field_errors, format_location
from supervisor.config.scenario_schema import Scenario
from supervisor.errors import ScenarioError

# --- error messages ---------------------------------------------------------------------------------------


def _show(value: object) -> str:
    """A bad value for a message: one line (repr escapes line breaks), at most 60 characters."""
    if isinstance(value, dict):
        return "a table"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _child(data: object, part: int | str) -> tuple[bool, object]:
    """(True, data[part]) if part is a key or index of data, else (False, None)."""
    if isinstance(data, dict) and part in data:
        return True, data[part]
    if isinstance(data, list | tuple) and isinstance(part, int) and 0 <= part < len(data):
        return True, data[part]
    return False, None


def _file_location(loc: tuple[int | str, ...], data: object, missing: bool) -> list[int | str]:
    """pydantic's loc without the union-member tags it inserts ('helix', 'float', ...): the parts that index
    the parsed TOML, plus a missing key at the end."""
    out: list[int | str] = []
    for position, part in enumerate(loc):
        found, child = _child(data, part)
        if found:
            out.append(part)
            data = child
        elif missing and position == len(loc) - 1:
            out.append(part)
    return out


SHOWN_ITEMS = 10  # a list refused as too long is shown up to this many items, else counted
_PROBLEMS = {
    "missing": "missing required field",
    "extra_forbidden": "unknown key",
    "tuple_type": "must be an array",
    "dict_type": "must be a table",
    "model_type": "must be a table",
    "string_pattern_mismatch": "must be a name of letters, digits, '_', '-', '+' and '.' (not starting with '.'), "
    "not a path",
}


def _describe(error: ErrorDetails, data: object) -> tuple[str, str]:
    """(field, problem) of one pydantic error, in terms of the file."""
    kind, value, ctx = error["type"], error.get("input"), error.get("ctx", {})
    loc = _file_location(error["loc"], data, kind == "missing")
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        loc.append(str(ctx["discriminator"]).strip("'"))
        if kind == "union_tag_not_found":
            return format_location(loc), _PROBLEMS["missing"]
        return format_location(loc), f"must be one of {ctx['expected_tags']}, got {_show(ctx['tag'])}"
    if kind == "missing" and loc and isinstance(loc[-1], int):  # a short array: pydantic reports its first absent item
        return format_location(loc[:-1]), f"too few items, got {_show(value)}"
    problem = _PROBLEMS.get(kind) or error["msg"].removeprefix("Value error, ")
    problem = problem.replace("Input should be", "must be").replace("Tuple should have", "must have")
    shown = "" if kind in ("missing", "extra_forbidden") else f", got {_show(value)}"
    if kind == "too_long" and isinstance(value, list | tuple) and len(value) > SHOWN_ITEMS:  # 10001 vehicles
        shown = f", got {len(value)}"
    return format_location(loc), re.sub(r" after validation, not \d+$", "", problem) + shown


def _pydantic_errors(exc: ValidationError, data: object) -> list[str]:
    """One '<field>: <problem>, got <value>' per field pydantic rejected, a misspelt key first (it also makes the
    real one "missing"). A union's members' complaints about one field become one line; a collection's "too few
    items" that only counts the items rejected on their own is left out."""
    errors = exc.errors()
    errors.sort(key=lambda e: e["type"] != "extra_forbidden")
    locs = [e["loc"] for e in errors]
    kept = [e for e in errors if not (e["type"] == "too_short" and _has_inner(e["loc"], locs))]
    by_field: dict[str, list[str]] = {}
    for error in kept:
        field, problem = _describe(error, data)
        by_field.setdefault(field, []).append(problem)
    return [f"{field}: {_either(problems)}" for field, problems in by_field.items()]


def _has_inner(loc: tuple[int | str, ...], locs: list[tuple[int | str, ...]]) -> bool:
    return any(len(other) > len(loc) and other[: len(loc)] == loc for other in locs)


def _either(problems: list[str]) -> str:
    """'must be a valid number, got 'x'' and 'must be 'closest', got 'x'' -> 'must be a valid number or 'closest',
    got 'x''."""
    if len(problems) == 1:
        return problems[0]
    heads = [p.rpartition(", got ")[0] or p for p in problems]
    got = problems[0].rpartition(", got ")[2] if ", got " in problems[0] else ""
    wanted = [heads[0], *(h.removeprefix("must be ") for h in heads[1:])]
    return " or ".join(dict.fromkeys(wanted)) + (f", got {got}" if got else "")


def _line(source: str, message: str) -> str:
    """'<source>: <message>', forced onto one line whatever the source and message hold."""
    return "\\n".join(f"{source}: {message}".splitlines())


def _error(source: str, message: str) -> ScenarioError:
    return ScenarioError(_line(source, message))


def _errors(lines: list[str]) -> ScenarioError:
    """One ScenarioError for every error found: a line each, the first the usual one-line message."""
    return ScenarioError("\n".join(lines), lines)


# --- validation ---------------------------------------------------------------------------------------------

_SECTIONS: dict[str, TypeAdapter[Any]] = {}


def _section_adapter(name: str) -> TypeAdapter[Any]:
    """A validator of one top-level section, exactly as Scenario validates it (its type and constraints)."""
    if name not in _SECTIONS:
        info = Scenario.model_fields[name]
        section: Any = Annotated[info.annotation, info]  # a type built at run time: mypy cannot follow it
        _SECTIONS[name] = TypeAdapter(section)
    return _SECTIONS[name]


def _partial(data: dict[str, Any], rejected: set[str]) -> Scenario:
    """A Scenario of the sections pydantic accepted (the rejected ones at their defaults, or absent): the
    cross-field rules that read only accepted sections can still run on it."""
    good = {
        name: _section_adapter(name).validate_python(data[name])
        for name in Scenario.model_fields
        if name not in rejected and name in data
    }
    return Scenario.model_construct(**good)


def _validate(data: dict[str, Any]) -> tuple[Scenario | None, list[str]]:
    """(the scenario if valid, every error '<field>: <problem>, got <value>': pydantic's, then the cross-field
    rules' on the sections pydantic accepted)."""
    too_deep = _too_deep(data)
    if too_deep is not None:
        return None, [f"{format_location(too_deep)}: nested more than {MAX_DEPTH} levels deep"]
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        rejected = {str(e["loc"][0]) for e in exc.errors() if e["loc"]}
        if not isinstance(data, dict) or any(not e["loc"] for e in exc.errors()):
            return None, _pydantic_errors(exc, data)
        try:
            partial = _partial(data, rejected)
        except ValidationError:  # cannot happen (each section on its own as in the whole): report what we have
            return None, _pydantic_errors(exc, data)
        return None, _pydantic_errors(exc, data) + cross_field_errors(partial, rejected)
    errors = cross_field_errors(scenario)
    return (None if errors else scenario), errors


def scenario_errors(data: dict[str, Any], source: str) -> list[str]:
    """Every error of a parsed scenario (TOML as a dict, --set and --fault applied), one line each:
    '<source>: <field>: <problem>, got <value>'; [] if it is valid. For tools that report rather than stop
    (cpf validate); validate_data raises them instead."""
    return [_line(source, line) for line in dict.fromkeys(_validate(data)[1])]


# --- entry points -----------------------------------------------------------------------------------------


def validate_data(data: dict[str, Any], source: str) -> Scenario:
    """Scenario from parsed TOML; otherwise a ScenarioError with every error, one line each
    ('<source>: <field>: <problem>, got <value>'), in its message and its errors."""
    scenario, errors = _validate(data)
    if scenario is None:
        raise _errors([_line(source, line) for line in dict.fromkeys(errors)])
    return scenario


def parse_scenario(
    text: str, source: str = "<string>", overrides: Sequence[str] = (), faults: Sequence[str] = ()
) -> Scenario:
    """Scenario from TOML text, KEY=VALUE overrides and extra faults ("kind=link_down,sender=1,..."); a
    ScenarioError('<source>: <field>: ...') otherwise."""
    try:  # a byte-order mark, as some editors write, skipped (TOML's parser: 'invalid statement' at line 1)
        data = tomllib.loads(text.removeprefix("\ufeff"))
    except (tomllib.TOMLDecodeError, ValueError) as exc:  # ValueError: an integer of more than 4300 digits
        raise _error(source, f"invalid TOML: {exc}") from exc
    except RecursionError:
        raise _error(source, f"invalid TOML: arrays or tables nested too deeply (at most {MAX_DEPTH} levels)") from None
    for override in overrides:
        apply_override(data, override)
    extra = [fault_table(fault) for fault in faults]
    present = data.setdefault("faults", []) if extra else None
    if isinstance(present, list):  # not a list: validation says what `faults` must be (it was an AttributeError)
        present.extend(extra)
    return validate_data(data, source)


MAX_DEPTH = 10  # arrays and tables in one another: a scenario needs 5 ([[faults]] edges = [[1, 2]])


def _too_deep(data: object) -> list[int | str] | None:
    """Where data holds arrays and tables more than MAX_DEPTH levels deep, or None. Iterative: the depth checked is
    the one no recursive code that comes later (validation, messages) could handle."""
    stack: list[tuple[object, list[int | str]]] = [(data, [])]
    while stack:
        node, loc = stack.pop()
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for key, child in items:
            if isinstance(child, dict | list):
                if len(loc) + 1 >= MAX_DEPTH:
                    return [*loc, key]
                stack.append((child, [*loc, key]))
    return None


def _toml_value(text: str, what: str) -> object:
    """A --set or --fault value as TOML reads it; a bare word (not TOML) is a string."""
    try:
        return tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()
    except ValueError as exc:  # an integer of more than 4300 digits
        raise ScenarioError(f"{what}: {exc}, got {_show(text)}") from None
    except RecursionError:
        raise ScenarioError(f"{what}: nested too deeply (at most {MAX_DEPTH} levels), got {_show(text)}") from None


def fault_table(spec: str) -> dict[str, Any]:
    """A --fault value as the table [[faults]] would hold: comma-separated KEY=VALUE, values as TOML values."""
    table: dict[str, Any] = {}
    for part in split_outside_brackets(spec):
        key, sep, text = part.partition("=")
        if not sep or not key.strip():
            raise ScenarioError(f"--fault: expected KEY=VALUE pairs separated by commas, got {spec!r}")
        if key.strip() in table:  # TOML refuses a key given twice: so does its one-line form (the last one won)
            raise ScenarioError(f"--fault {key.strip()}: given twice, got {spec!r}")
        table[key.strip()] = _toml_value(text, f"--fault {key.strip()}")
    return table


def split_outside_brackets(spec: str) -> list[str]:
    """Split at commas outside brackets, braces and quoted strings, so edges=[[1,2],[2,3]], a table {a=1, b=2} and
    a string "a,b" each stay whole."""
    parts, depth, current = [], 0, ""
    quote, escaped = "", False
    for char in spec:
        if escaped:  # the character after a backslash in a "..." string
            escaped = False
        elif quote:  # inside "..." (backslash escapes) or '...' (literal): nothing counts but its end
            escaped = char == "\\" and quote == '"'
            quote = "" if char == quote else quote
        elif char in "\"'":
            quote = char
        else:
            depth += {"[": 1, "]": -1, "{": 1, "}": -1}.get(char, 0)
        if char == "," and depth == 0 and not quote:
            parts.append(current)
            current = ""
        else:
            current += char
    return [p for p in [*parts, current] if p.strip()]


def apply_override(data: dict[str, Any], override: str) -> None:
    """Set a dotted key (list items by index: vehicles.0.gamma0) to a TOML value; bare words are strings."""
    key, sep, text = override.partition("=")
    if not sep or not key.strip():
        raise ScenarioError(f"--set: expected KEY=VALUE, got {override!r}")
    value = _toml_value(text, f"--set {key.strip()}")
    node: Any = data
    parts = key.strip().split(".")
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        if isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node[int(part)] = value if last else node[int(part)]
            node = node[int(part)]
        elif isinstance(node, dict):
            if last:
                node[part] = value
            node = node.setdefault(part, {})
        else:
            raise ScenarioError(f"--set {key}: no such place in the scenario, got {override!r}")


def load_scenario(path: Path, overrides: Sequence[str] = (), faults: Sequence[str] = ()) -> Scenario:
    """Read and validate a scenario file (UTF-8, as TOML requires)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise _error(str(path), f"cannot read scenario file: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise _error(str(path), f"invalid TOML: not UTF-8 text (byte {exc.start})") from exc
    return parse_scenario(text, str(path), overrides, faults)

"""Values as TOML text: what --set, --param and a scenario given as a dict hand the scenario loader, which reads
TOML (supervisor.config.scenario). One writer for the Python API (cpf.inputs) and the sweep's runs
(supervisor.tools.sweep_runs): each had its own, and the sweep's wrote JSON, whose tables TOML does not read."""

from __future__ import annotations

import json
import math
import numbers
from collections.abc import Mapping
from typing import Any

from supervisor.errors import ScenarioError


def toml_value(value: Any) -> str:
    """A value as TOML writes it (tables inline); ScenarioError for one TOML has no form for (None, objects)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        number = float(value)
        return (
            ("nan" if math.isnan(number) else f"{'-' if number < 0 else ''}inf")
            if not math.isfinite(number)
            else repr(number)
        )
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, Mapping):
        return "{" + ", ".join(toml_assignment(k, v) for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise ScenarioError(f"scenario: TOML has no value like {value!r} ({type(value).__name__})")


def toml_assignment(key: str, value: Any) -> str:
    return f"{toml_key(key)} = {toml_value(value)}"


def toml_key(key: str) -> str:
    bare = key and all(c.isascii() and (c.isalnum() or c in "_-") for c in key)
    return key if bare else toml_string(key)


def toml_string(text: str) -> str:
    """A TOML basic string: JSON's escapes are TOML's too, but for characters beyond the BMP, which JSON's ASCII
    form writes as surrogate pairs (TOML refuses them: written as they are here), and DEL, which TOML wants escaped."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")

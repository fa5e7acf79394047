"""A sweep's parameters: `--param KEY=v1,v2,...` or `KEY=start:stop:step` read into a Param (the key and its values),
refused with a one-line ScenarioError naming --param where it is not one (supervisor.tools.sweep runs the grid)."""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from typing import Any

from supervisor.config.scenario import split_outside_brackets
from supervisor.errors import ScenarioError

# Keys a sweep sets itself: each run's seed is the sweep's (0 .. seeds-1), which overrides the scenario's
SWEEP_OWN = {"scenario.seed": "a sweep gives each run its seed (0 .. N-1 of --seeds N; seeds=N in cpf.sweep) over the "
             "scenario's: sweep seeds with --seeds"}  # fmt: skip


@dataclass(frozen=True, slots=True)
class Param:
    key: str
    values: tuple[Any, ...]


def parse_param(text: str) -> Param:
    """KEY=v1,v2,... (TOML values; commas inside brackets belong to a value, so graphs can be swept:
    graph.edges=[[1,2],[1,3]],[[1,2],[2,3]]) or KEY=start:stop:step (inclusive of stop, within rounding)."""
    key, sep, spec = text.partition("=")
    if not sep or not key.strip() or not spec.strip():
        raise ScenarioError(f"--param: expected KEY=v1,v2,... or KEY=start:stop:step, got {text!r}")
    if key.strip() in SWEEP_OWN:
        raise ScenarioError(f"--param {key.strip()}: {SWEEP_OWN[key.strip()]}, got {text!r}")
    parts = spec.split(":")
    numbers = len(parts) > 1 and all(_NUMBER.match(part.strip()) for part in parts)
    if numbers and len(parts) != 3:
        raise ScenarioError(f"--param {key}: a range needs start:stop:step, got {spec!r}")
    if numbers:  # not names with a colon (my_pkg.laws:Law,my_pkg.laws:Other): a list of them
        start, stop, step = (_value(part, text) for part in parts)
        if step <= 0 or stop < start:
            raise ScenarioError(f"--param {key}: start:stop:step needs step > 0 and stop >= start, got {spec!r}")
        count = math.floor((stop - start) / step + 1e-9) + 1
        return Param(key.strip(), tuple(round(start + i * step, 12) for i in range(count)))
    return Param(key.strip(), tuple(_value(part, text) for part in split_outside_brackets(spec)))


_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")  # what a range's ends and step look like
BARE_WORD = re.compile(r"^[A-Za-z_][\w.-]*(:[A-Za-z_][\w.]*)?$")  # a name (corrected, my_pkg.laws:Law): a string


def _value(text: str, whole: str) -> Any:
    """A TOML value; a bare word is a string, as with --set (a law's or a predictor's name)."""
    try:
        return tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        if BARE_WORD.match(text.strip()) and text.strip() not in ("true", "false", "inf", "nan"):
            return text.strip()
        raise ScenarioError(f"--param: {text.strip()!r} is not a TOML value, in {whole!r}") from None

"""Property-based tests of every input a user gives: scenario files, --set values and --fault specs, with garbage and
extreme values. Whatever they hold, `cpf validate` (the load path every command shares) answers with exit 0 or with
one-line errors naming the file (exit 2), never a traceback. Then the cases the issue found, one by one.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import tomllib
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from supervisor.cli import main
from supervisor.config.scenario_schema import Scenario
from tests.conftest import CONFIGS

PAPER = CONFIGS / "paper.toml"
EVERY_FAULT = CONFIGS / "examples" / "every_fault.toml"
FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# --- values as a fuzzer would write them ----------------------------------------------------------------------

EXTREME_FLOATS = [0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e308, -1e308, 1.7976931348623157e308, 3.5e38, 1e7, 4294967.296]
floats = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(EXTREME_FLOATS))
ints = st.one_of(
    st.integers(min_value=-(2**70), max_value=2**70), st.sampled_from([0, -1, 255, 256, 2**63, 2**64, 10**400])
)
scalars = st.one_of(floats, ints, st.booleans(), st.text(max_size=30), st.sampled_from(["closest", "helix", ""]))
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=3)),
    max_leaves=12,
)


def toml_value(value: Any) -> str:
    """A value as an inline TOML value (nan and inf as TOML writes them)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return ("-" if value < 0 else "") + "inf" if math.isinf(value) else "nan" if math.isnan(value) else repr(value)
    if isinstance(value, int | str):
        return json.dumps(value)  # JSON strings are TOML basic strings (a lone surrogate is invalid TOML: fine)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    return "[" + ", ".join(toml_value(item) for item in value) + "]"


def toml_file(data: dict[str, Any]) -> str:
    """A whole scenario as TOML: top-level values first, then one [table] per section of inline values."""
    plain = [f"{json.dumps(k)} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    tables = [
        f"[{json.dumps(k)}]\n" + "\n".join(f"{json.dumps(key)} = {toml_value(v)}" for key, v in section.items())
        for k, section in data.items()
        if isinstance(section, dict)
    ]
    return "\n".join(plain) + "\n" + "\n".join(tables) + "\n"


def leaf_paths(node: Any, prefix: tuple[str | int, ...] = ()) -> list[tuple[str | int, ...]]:
    if isinstance(node, dict):
        return [p for k, v in node.items() for p in leaf_paths(v, (*prefix, k))] or [prefix]
    if isinstance(node, list):
        return [p for i, v in enumerate(node) for p in leaf_paths(v, (*prefix, i))] or [prefix]
    return [prefix]


def model_keys(model: type[Any], prefix: str = "") -> list[str]:
    """Dotted keys of every field of the scenario's sections (lists of tables are covered by the files' leaves)."""
    out = []
    for name, info in model.model_fields.items():
        annotation = info.annotation
        if isinstance(annotation, type) and hasattr(annotation, "model_fields"):
            out += model_keys(annotation, f"{prefix}{name}.")
        else:
            out.append(f"{prefix}{name}")
    return out


BASE = tomllib.loads(EVERY_FAULT.read_text())
KNOWN_KEYS = sorted(
    set(model_keys(Scenario)) | {".".join(map(str, p)) for f in (PAPER, EVERY_FAULT) for p in leaf_paths(
        tomllib.loads(f.read_text()))}
)  # fmt: skip
FAULT_FIELDS = ["kind", "vehicle", "sender", "receiver", "start", "end", "offset", "gamma_dot_max", "extra_loss",
                "extra_delay", "both", "edges"]  # fmt: skip
FAULT_KINDS = ["speed_cap", "link_down", "link_degraded", "blackout", "modem_silent", "graph_switch", "vehicle_kill",
               "broker_kill", "frozen_gamma", "gamma_offset", "clock_skew", "nonsense"]  # fmt: skip


def validate(*argv: str) -> tuple[int, list[str]]:
    """cpf validate in this process: (exit code, stderr lines). Any exception but the CLI's own handling escapes."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["validate", *argv])
    return code, err.getvalue().splitlines()


def assert_clean(code: int, lines: list[str], source: Path) -> None:
    """Exit 0, or exit 2 with every error line the usual one: 'cpf: error: <file>: <field>: ...'."""
    assert code in (0, 2), lines
    errors = [line for line in lines if line.startswith("cpf: error:")]
    assert (code == 2) == bool(errors), lines
    for line in errors:
        assert line.startswith(f"cpf: error: {source}: ") or line.startswith("cpf: error: --"), line
        assert len(line) < 2000, line  # one readable line, not a dump of the value


# --- properties -------------------------------------------------------------------------------------------------


def _mutated(data: Any, path: tuple[str | int, ...], value: Any) -> Any:
    if not path:
        return value
    head, rest = path[0], path[1:]
    if isinstance(data, dict):
        return {**data, str(head): _mutated(data.get(head, {}), rest, value)}
    if isinstance(data, list) and isinstance(head, int) and head < len(data):
        return [_mutated(item, rest, value) if i == head else item for i, item in enumerate(data)]
    return value


@FUZZ
@given(changes=st.lists(st.tuples(st.sampled_from(leaf_paths(BASE)), values), min_size=1, max_size=4))
def test_a_scenario_file_with_garbage_values_gives_one_line_errors_never_a_traceback(tmp_path_factory, changes):
    data: Any = BASE
    for path, value in changes:
        data = _mutated(data, path, value)
    source = tmp_path_factory.mktemp("fuzz") / "s.toml"
    source.write_text(toml_file(data), encoding="utf-8")
    assert_clean(*validate(str(source)), source)


@FUZZ
@given(depth=st.integers(1, 3000), where=st.sampled_from(["seed", "graph", "extra", "inline"]))
def test_deeply_nested_arrays_and_tables_are_refused_in_one_line(tmp_path_factory, depth, where):
    nested = "[" * depth + "]" * depth if where != "inline" else "{a = " * depth + "1" + "}" * depth
    text = PAPER.read_text()
    text = {"seed": text.replace("seed = 0", f"seed = {nested}"), "graph": text.replace(
        "edges = [[1, 2], [1, 3]]", f"edges = {nested}")}.get(where, text + f"\n[extra]\nx = {nested}\n")  # fmt: skip
    source = tmp_path_factory.mktemp("deep") / "s.toml"
    source.write_text(text)
    code, lines = validate(str(source))
    assert code == 2
    assert_clean(code, lines, source)


set_values = st.one_of(
    floats.map(toml_value), ints.map(str), values.map(toml_value), st.text(max_size=20),
    st.sampled_from(["inf", "-inf", "nan", "1e308", "-1e308", "0", "1e-300", "[" * 600 + "]" * 600, "9" * 5000]),
)  # fmt: skip


@FUZZ
@given(key=st.sampled_from(KNOWN_KEYS), value=set_values)
def test_set_with_any_value_on_any_known_key_gives_one_line_errors_never_a_traceback(key, value):
    assert_clean(*validate(str(PAPER), "--set", f"{key}={value}"), PAPER)


@FUZZ
@given(
    kind=st.sampled_from(FAULT_KINDS),
    fields=st.dictionaries(st.sampled_from(FAULT_FIELDS[1:]), set_values.filter(lambda v: "," not in v), max_size=5),
)
def test_fault_specs_with_extreme_values_give_one_line_errors_never_a_traceback(kind, fields):
    spec = ",".join([f"kind={kind}", *(f"{k}={v}" for k, v in fields.items())])
    assert_clean(*validate(str(PAPER), "--fault", spec), PAPER)


# --- a value cpf validate accepts runs --------------------------------------------------------------------------

BOUNDARY_SETS = [
    "comms.sound_speed=1000", "comms.sound_speed=2000", "coordination.v_r=-250", "coordination.v_r=250",
    "vehicles.0.gamma0=1e6", "vehicles.0.gamma0=-1e6", "scenario.seed=18446744073709551615",
    "vehicles.0.velocity=[-5.0,5.0,-5.0]", "vehicles.0.angular_velocity=[10.0,-10.0,10.0]",
    "vehicles.0.position=[1e7,-1e7,1e7]", "vehicles.0.attitude_rpy_deg=[360.0,-360.0,360.0]",
    "comms.jitter=3600", "comms.bitrate=1", "comms.packet_bytes=1000000", "comms.frame_bytes=1000000",
]  # fmt: skip


# A spin of 10 rad/s or a 5 m/s sideways start of a vehicle with Prestero's drag (M_q|q| 188, N_r|r| 94) is too stiff
# for RK4 at the paper's 0.1 s step: the run stops with the one-line divergence error, which says a shorter step may
# help. At the step it needs, a value on the bound runs.
STIFF_STEP = {"vehicles.0.velocity=[-5.0,5.0,-5.0]": "0.01", "vehicles.0.angular_velocity=[10.0,-10.0,10.0]": "0.002"}


@pytest.mark.parametrize("change", BOUNDARY_SETS)
def test_a_value_at_its_bound_is_accepted_and_runs(tmp_path, change):
    """The bounds are not just refusals: a value on one passes cpf validate and runs to the end (in process)."""
    out = tmp_path / "r.mcap"
    argv = ["run", str(PAPER), "--engine", "inprocess", "--quiet", "--set", "scenario.duration=1", "--set", change]
    argv += ["--set", f"scenario.step={STIFF_STEP[change]}"] if change in STIFF_STEP else []
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main([*argv, "--set", "faults=[]", "--out", str(out)])
    assert code == 0, err.getvalue()

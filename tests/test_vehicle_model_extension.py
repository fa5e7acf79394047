"""The vehicle model as an extension point (issue 22): a user's model named by import path runs the paper scenario on
both engines with the same records; a broken one is one line and the right exit code, before the run (2) or when it
breaks (1); its identity reaches the hello digest, the log's meta and `cpf info`; the presets are built-in models,
built through the same registry with [vehicle] overrides as their options.

    vehicle 2 -- vehicle 1 -- vehicle 3      (the paper's graph, 20 s of its scenario)
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest

from supervisor.config.explain import what_would_run
from supervisor.config.extensions import build
from supervisor.config.fleet import vehicle_config
from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_digest import section_digests
from supervisor.config.vehicle_models import params_of
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf
from vehicles.guard import Guarded
from vehicles.params import PRESETS
from vehicles.vehicle_model import Remus100Legacy

ROOT = Path(__file__).resolve().parent.parent
ENV = {"PYTHONPATH": str(ROOT)}  # tests.samples importable in every process of the run
SAMPLES = "tests.samples.vehicles"
HEAVY = f"vehicle.model={SAMPLES}:Heavy"


def run(tmp_path: Path, *options: str, engine: str = "inprocess", seconds: float = 20.0):
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), seconds))
    args = ["run", str(scenario), "--engine", engine, "--quiet", "--out", "run.mcap"]
    return cpf(*args, *(x for o in options for x in ("--set", o)), cwd=tmp_path, env=ENV)


def one_line(text: str) -> str:
    lines = [line for line in text.splitlines() if line.startswith("cpf: error")]
    assert len(lines) == 1, text
    return lines[0]


def states(log: Path) -> list[tuple[int, str]]:
    return sorted((t, str(m)) for topic, t, m in read_messages(log) if topic.endswith("/state"))


def test_a_vehicle_model_by_import_path_gives_the_same_records_on_both_engines(tmp_path):
    runs = (("in", "inprocess", (HEAVY,)), ("zenoh", "zenoh", (HEAVY,)), ("builtin", "inprocess", ()))
    for sub, engine, options in runs:
        (tmp_path / sub).mkdir()
        done = run(tmp_path / sub, *options, engine=engine)
        assert done.returncode == 0, done.stderr
    inprocess, zenoh, builtin = (states(tmp_path / sub / "run.mcap") for sub in ("in", "zenoh", "builtin"))
    assert inprocess == zenoh and len(inprocess) == 600
    assert inprocess != builtin  # the vehicles moved as the heavier model: not the preset's records
    meta = next(m for topic, _, m in read_messages(tmp_path / "zenoh" / "run.mcap") if topic == "cpf/run/meta")
    assert any(e.startswith(f"model {SAMPLES}:Heavy = {SAMPLES}:Heavy (") for e in meta["extensions"])
    info = cpf("info", "run.mcap", cwd=tmp_path / "zenoh", env=ENV)
    assert f"model {SAMPLES}:Heavy" in info.stdout


@pytest.mark.parametrize(
    ("settings", "expected"),
    [
        (["vehicle.model=no_such_module:Auv"], "vehicle.model: cannot import 'no_such_module'"),
        (["vehicle.model=bogus"], "vehicle.model: no model 'bogus' (installed: remus100, remus100_legacy"),
        ([f"vehicle.model={SAMPLES}:NoDrift"], "lacks the model interface (VehicleModel)"),
        ([f"vehicle.model={SAMPLES}:WrongSignature"],
         f"vehicle.model: {SAMPLES}:WrongSignature.drift cannot be called with the interface's arguments (s, params)"),
        ([f"vehicle.model={SAMPLES}:NoParameters"],
         "vehicle.model: parameters() returned dict, not a VehicleParams"),
        ([HEAVY, "vehicle.model_options.mass=[-1.0, 1.0, 1.0]"],
         "vehicle.model_options.mass.0: Input should be greater than 0, got -1.0"),
        ([HEAVY, "vehicle.model_options.mas=1.0"],
         f"vehicle.model_options.mas: {SAMPLES}:Heavy has no such option (its options: angular_linear_damping"),
        ([HEAVY, "vehicle.overrides.max_torque=10.0"],
         "vehicle.overrides: a vehicle.model takes its options from vehicle.model_options"),
        (["vehicle.model_options.mass=[40.0, 60.0, 60.0]"],
         "vehicle.model_options: a preset takes its changes from [vehicle] overrides"),
        ([HEAVY, "vehicles.0.overrides.max_torque=3.0"],  # named preset, which was not given (a new user's)
         f"vehicles[0].overrides: the fleet runs vehicle.model {SAMPLES}:Heavy: no preset or overrides of its own"),
        ([HEAVY, "vehicles.0.preset=remus100"],
         f"vehicles[0].preset: the fleet runs vehicle.model {SAMPLES}:Heavy: no preset or overrides of its own"),
        # the ranges [vehicle] overrides are held to (a new user's negative thrust ran)
        ([HEAVY, "vehicle.model_options.max_surge_force=-5.0"],
         f"vehicle.model: parameters() gives max_surge_force -5.0, outside [0, 1e+06], got '{SAMPLES}:Heavy'"),
    ],
)  # fmt: skip
def test_a_bad_vehicle_model_or_option_is_one_line_and_exit_2_before_the_run(tmp_path, settings, expected):
    done = run(tmp_path, *settings)
    assert done.returncode == 2 and expected in one_line(done.stderr), done.stderr
    assert not (tmp_path / "run.mcap").exists()


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("Raises", f"model {SAMPLES}:Raises raised ZeroDivisionError: no water"),
        ("NotFinite", f"model {SAMPLES}:NotFinite returned nan, not a finite number"),
    ],
)
def test_a_vehicle_model_that_breaks_stops_the_run_with_one_line_naming_it(tmp_path, engine, name, expected):
    done = run(tmp_path, f"vehicle.model={SAMPLES}:{name}", engine=engine, seconds=5.0)
    line = one_line(done.stderr)
    assert done.returncode == 1 and expected in line and "vehicle " in line and " at t = " in line, done.stderr
    assert " at t = 0.0 s" not in line  # it broke under way, as the sample does, not at the first call
    assert "Traceback" not in done.stderr
    assert cpf("info", "run.mcap", cwd=tmp_path, env=ENV).returncode == 0  # the log was closed


def test_the_hello_digest_covers_the_vehicle_model():
    here = section_digests(load_scenario(CONFIGS / "paper.toml"))
    other = section_digests(load_scenario(CONFIGS / "paper.toml", [HEAVY]))
    assert {k for k in here if other[k] != here[k]} == {"vehicle", "extensions"}


def test_the_presets_are_built_through_the_registry_with_their_overrides_as_options():
    legacy, identity = build("model", "remus100_legacy", {"max_torque": 10.0}, {"dimension": 2})
    assert identity.builtin and identity.target == "vehicles.vehicle_model:Remus100Legacy"
    assert legacy == Remus100Legacy(max_torque=10.0, dimension=2)
    for name, numbers in PRESETS.items():
        assert build("model", name, {})[0].parameters() == numbers
    settings = [
        "vehicle.overrides.max_torque=12.0",
        "vehicles.1.preset=remus100_legacy",
        "vehicles.1.overrides.weight=300.0",
    ]
    sc = load_scenario(CONFIGS / "paper.toml", settings)
    assert params_of(sc, 1) == replace(PRESETS[sc.vehicle.preset], max_torque=12.0)
    assert params_of(sc, 2) == replace(PRESETS["remus100_legacy"], max_torque=12.0, weight=300.0)
    heavy = load_scenario(CONFIGS / "paper.toml", [HEAVY])
    assert f"3 vehicles ({SAMPLES}:Heavy, the 6-DOF model)" in what_would_run(heavy)  # cpf validate's paragraph
    users = vehicle_config(heavy, 1)
    assert isinstance(users.vehicle, Guarded) and users.vehicle.label == f"model {SAMPLES}:Heavy"
    assert users.params.mass == (43.9, 72.5, 72.5)


def test_cpf_plugins_lists_the_presets_as_vehicle_models(tmp_path):
    done = cpf("plugins", cwd=tmp_path)
    assert done.returncode == 0
    assert "vehicle.model (entry points cpf.vehicles):" in done.stdout
    rows = [line for line in done.stdout.splitlines() if "vehicles.vehicle_model:" in line]
    assert [row.split()[:2] for row in rows] == [
        ["remus100", "vehicles.vehicle_model:Remus100"],
        ["remus100_legacy", "vehicles.vehicle_model:Remus100Legacy"],
        ["remus100_neutral", "vehicles.vehicle_model:Remus100Neutral"],
    ]
    assert len({row.index("vehicles.vehicle_model:") for row in rows}) == 1  # one column, the longest name too
    assert "options: angular_linear_damping, angular_quadratic_damping, buoyancy, center_of_buoyancy" in done.stdout


def test_the_vehicle_model_of_docs_extending_builds_with_its_numbers(tmp_path, monkeypatch):
    doc = (ROOT / "docs" / "extending.md").read_text(encoding="utf-8")
    (code,) = re.findall(r"<!-- a vehicle model, checked by [^>]*-->\n```python\n(.*?)```", doc, flags=re.S)
    (tmp_path / "doc_vehicle.py").write_text(code)
    monkeypatch.syspath_prepend(str(tmp_path))
    heavy, identity = build("model", "doc_vehicle:Heavy", {"max_torque": 15.0}, {"dimension": 2})
    assert not identity.builtin and heavy.dimension == 2
    params = heavy.parameters()
    assert params.mass == (43.9, 72.5, 72.5) and params.max_torque == 15.0
    assert params.linear_damping == PRESETS["remus100"].linear_damping  # what it does not change is the preset's

"""Extension points (issue 22): a law, predictor or transmission policy named by import path or entry point runs on
both engines; a broken one is one line and the right exit code, before the run (2) or when it breaks (1); its
identity reaches the hello digest, the log's meta and `cpf info`; the built-ins are listed by `cpf plugins`."""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from comms.bus.handover import write_private
from supervisor.config.extensions import build, instantiate, plugins_text, resolve
from supervisor.config.scenario import load_scenario
from supervisor.config.scenario_digest import section_digests
from supervisor.record.recorder import read_messages
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf
from vehicles.coordination import CoordinationGains
from vehicles.guard import Guarded
from vehicles.start import read_starts

ROOT = Path(__file__).resolve().parent.parent
ENV = {"PYTHONPATH": str(ROOT)}  # tests.samples importable in every process of the run
SAMPLES = "tests.samples.laws"


def run(tmp_path: Path, *options: str, engine: str = "inprocess", seconds: float = 200.0):
    scenario = tmp_path / "s.toml"
    scenario.write_text(shortened((CONFIGS / "paper.toml").read_text(), seconds))
    args = ["run", str(scenario), "--engine", engine, "--quiet", "--out", "run.mcap"]
    return cpf(*args, *(x for o in options for x in ("--set", o)), cwd=tmp_path, env=ENV)


def one_line(text: str) -> str:
    lines = [line for line in text.splitlines() if line.startswith("cpf: error")]
    assert len(lines) == 1, text
    return lines[0]


@pytest.fixture(scope="module")
def damped(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, subprocess.CompletedProcess[str]]]:
    """The sample law with an option, 60 s of the paper scenario on each engine: (directory, cpf run) by engine.
    Run once for the module: the tests below look at the same two runs from different sides."""
    runs = {}
    for engine in ("inprocess", "zenoh"):
        where = tmp_path_factory.mktemp(engine)
        law = (f"coordination.law={SAMPLES}:Damped", "coordination.law_options.gain=0.3")
        runs[engine] = (where, run(where, *law, engine=engine, seconds=60.0))
    return runs


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_a_law_by_import_path_runs_on_both_engines_with_its_options(damped, engine):
    where, done = damped[engine]
    assert done.returncode == 0, done.stderr
    meta = next(m for topic, _, m in read_messages(where / "run.mcap") if topic == "cpf/run/meta")
    assert meta["extensions"][0].startswith(f"law {SAMPLES}:Damped = {SAMPLES}:Damped (")
    info = cpf("info", "run.mcap", cwd=where, env=ENV)
    assert f"extensions law {SAMPLES}:Damped" in info.stdout


def test_the_engines_record_the_same_with_an_extension(damped):
    assert all(done.returncode == 0 for _, done in damped.values())
    states = [
        sorted((t, str(m)) for topic, t, m in read_messages(damped[engine][0] / "run.mcap") if topic.endswith("/state"))
        for engine in ("inprocess", "zenoh")
    ]
    assert states[0] == states[1] and len(states[0]) == 3 * 600


def test_a_class_other_processes_cannot_import_runs_in_process_and_is_refused_in_one_line_over_zenoh(tmp_path):
    """A law made by a function (its class is local to it) ran in process and ended the Zenoh engine in a pickling
    traceback (found by a new user): refused before anything starts, naming the field."""
    law = f"coordination.law={SAMPLES}:Made"
    assert run(tmp_path, law, seconds=5.0).returncode == 0
    done = run(tmp_path, law, engine="zenoh", seconds=5.0)
    assert done.returncode == 2
    assert one_line(done.stderr).endswith(
        f"coordination.law: {SAMPLES}:Made is defined inside a function; the zenoh engine's processes import an "
        f"extension by its module: put it at the top of a module on their PYTHONPATH, or run --engine inprocess, got "
        f"'{SAMPLES}:Made'"
    )


def test_a_start_holding_a_class_this_process_cannot_import_says_so(tmp_path):
    """What a vehicle process says when an extension's module is not on its path (a module the caller put on its
    sys.path by hand): not 'not vehicle starts written by cpf run'."""
    module = tmp_path / "only_here.py"
    module.write_text("class Law:\n    pass\n")
    sys.path.insert(0, str(tmp_path))
    try:
        import only_here

        write_private(tmp_path / "s.start", (only_here.Law(),))
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("only_here", None)
    with pytest.raises(ValueError, match=r"holding a class this process cannot import \(No module named 'only_here'\)"):
        read_starts(tmp_path / "s.start")


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
def test_a_predictor_of_ones_own_runs_and_cpf_stability_says_it_cannot_analyse_it(tmp_path, engine):
    """A user's predictor by import path runs (every such run ended in a ValueError: the check behind cpf validate's
    divergence warning linearised only the built-in predictors) and cpf stability refuses it in one line, exit 2."""
    predictor = f"coordination.predictor={SAMPLES}:Halfway"
    done = run(tmp_path, predictor, engine=engine, seconds=20.0)
    assert done.returncode == 0, done.stderr
    meta = next(m for topic, _, m in read_messages(tmp_path / "run.mcap") if topic == "cpf/run/meta")
    assert any(e.startswith(f"predictor {SAMPLES}:Halfway = ") for e in meta["extensions"]), meta["extensions"]
    stability = cpf("stability", "s.toml", "--set", predictor, cwd=tmp_path, env=ENV)
    assert stability.returncode == 2
    assert one_line(stability.stderr) == (
        "cpf: error: s.toml: coordination.predictor: the stability analysis models ('first_order', 'hold', "
        f"'reference'), got '{SAMPLES}:Halfway'; cpf stability cannot analyse this loop"
    )


@pytest.mark.parametrize(
    ("setting", "expected"),
    [
        ("coordination.law=no_such_module:Law", "coordination.law: cannot import 'no_such_module'"),
        ("coordination.law=bogus", "coordination.law: no law 'bogus' (installed: corrected, literal, saturated"),
        (f"coordination.law={SAMPLES}:NoCorrection", "lacks the law interface (CoordinationLaw)"),
        (f"coordination.law={SAMPLES}:Damped\0coordination.law_options.gain=-1",
         "coordination.law_options.gain: Input should be greater than 0, got -1"),
        (f"coordination.law={SAMPLES}:Damped\0coordination.law_options.gian=1",
         "coordination.law_options.gian: tests.samples.laws:Damped has no such option (its options: gain)"),
        ("coordination.predictor=first_order\0coordination.predictor_options.horizon=0",
         "coordination.predictor_options.horizon: Input should be greater"),
    ],
)  # fmt: skip
def test_a_bad_extension_or_option_is_one_line_and_exit_2_before_the_run(tmp_path, setting, expected):
    done = run(tmp_path, *setting.split("\0"))
    assert done.returncode == 2 and expected in one_line(done.stderr), done.stderr
    assert not (tmp_path / "run.mcap").exists()


@pytest.mark.parametrize("engine", ["inprocess", "zenoh"])
@pytest.mark.parametrize(
    ("law", "expected"),
    [
        ("Raises", "law tests.samples.laws:Raises raised ZeroDivisionError: float division by zero"),
        ("NotFinite", "law tests.samples.laws:NotFinite returned nan, not a finite number"),
        ("Slow", "law tests.samples.laws:Slow took 0.3"),
    ],
)
def test_an_extension_that_breaks_stops_the_run_with_one_line_naming_it(tmp_path, engine, law, expected):
    done = run(tmp_path, f"coordination.law={SAMPLES}:{law}", engine=engine, seconds=5.0)
    line = one_line(done.stderr)
    assert done.returncode == 1 and expected in line and " at t = " in line, done.stderr
    assert "Traceback" not in done.stderr
    assert cpf("info", "run.mcap", cwd=tmp_path, env=ENV).returncode == 0  # the log was closed


def test_the_hello_digest_covers_the_code_an_extension_resolves_to():
    sc = load_scenario(CONFIGS / "paper.toml", [f"coordination.law={SAMPLES}:Damped"])
    here = section_digests(sc)
    _, identity = resolve("law", f"{SAMPLES}:Damped")
    other = dataclasses.replace(identity, source_sha256="0" * 64)  # the same name, other code on another host
    resolve.cache_clear()
    try:
        import supervisor.config.extension_checks as checks

        original = checks.resolve
        checks.resolve = lambda kind, name: (None, other) if kind == "law" else original(kind, name)  # type: ignore
        assert section_digests(sc)["extensions"] != here["extensions"]
        assert {k for k in here if section_digests(sc)[k] != here[k]} == {"extensions"}
    finally:
        checks.resolve = original


def test_the_builtins_are_built_through_the_same_registry_with_their_options():
    law, identity = build("law", "saturated", {"k_c": 0.5})
    assert identity.builtin and identity.target == "vehicles.coordination:Saturated" and law.k_c == 0.5
    with pytest.raises(ValueError, match="width: Input should be greater than 0"):
        build("law", "saturated", {"width": 0})


def test_cpf_plugins_lists_every_builtin(tmp_path):
    done = cpf("plugins", cwd=tmp_path)
    assert done.returncode == 0
    for name in ("corrected", "literal", "saturated", "first_order", "hold", "reference", "periodic", "event"):
        assert f"  {name} " in done.stdout
    assert "options: horizon" in done.stdout and "options: k_c, width" in done.stdout


def test_a_class_signatures_are_inspected_once_unless_an_instance_or_the_class_changes_a_method(monkeypatch):
    """Every vehicle of a fleet builds the same extensions: the interface's signatures are read once per class
    (inspecting them 11000 times took 1.5 s of a 1000-AUV start), but an instance that holds a method of its own, or
    a method replaced on the class, is inspected again (a wrong signature still found before the run)."""
    from typing import Any, Protocol

    from supervisor.config import extensions

    class Speaks(Protocol):
        def say(self, word: str) -> str: ...

    class Plain:
        def say(self, word: str) -> str:
            return word

    inspected: list[object] = []
    real = extensions._problem_of

    def counted(instance: object, protocol: type) -> str | None:
        inspected.append(instance)
        return real(instance, protocol)

    monkeypatch.setattr(extensions, "_problem_of", counted)
    assert [extensions._signature_problem(Plain(), Speaks) for _ in range(5)] == [None] * 5
    assert len(inspected) == 1
    odd: Any = Plain()
    odd.say = lambda: "no word"
    assert extensions._signature_problem(odd, Speaks) is not None and len(inspected) == 2
    monkeypatch.setattr(Plain, "say", lambda self: "none")
    assert extensions._signature_problem(Plain(), Speaks) is not None and len(inspected) == 3

    class Chooses:  # what it calls is decided per instance (the review's): never kept per class
        def __init__(self, loud: bool) -> None:
            self.loud = loud

        @property
        def say(self) -> Any:
            return (lambda: "!") if self.loud else (lambda word: word)

    class Proxy:
        def __init__(self, inner: object) -> None:
            self._inner = inner

        def __getattr__(self, name: str) -> Any:
            return getattr(self._inner, name)

    for quiet, loud in ((Chooses(False), Chooses(True)), (Proxy(Chooses(False)), Proxy(odd))):
        assert extensions._signature_problem(quiet, Speaks) is None
        assert extensions._signature_problem(loud, Speaks) is not None


def _distribution(where: Path, name: str, group: str, entries: dict[str, str]) -> None:
    info = where / f"{name}-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in entries.items()))


def test_another_distribution_cannot_replace_a_builtin_by_its_name(tmp_path, monkeypatch):
    """A package declaring `corrected` in cpf.coordination ran every scenario with its law instead of law (5),
    silently (found by a new user): a built-in's name is the built-in's; a name two others declare is ambiguous."""
    _distribution(
        tmp_path, "shadow", "cpf.coordination", {"corrected": f"{SAMPLES}:Damped", "both": f"{SAMPLES}:Damped"}
    )
    _distribution(tmp_path, "other", "cpf.coordination", {"both": f"{SAMPLES}:Raises"})
    monkeypatch.syspath_prepend(str(tmp_path))
    resolve.cache_clear()
    try:
        _, identity = resolve("law", "corrected")
        assert identity.builtin and identity.target == "vehicles.coordination:Corrected"
        with pytest.raises(ValueError, match=r"'both' is declared by other .*, shadow .*: name the one you mean"):
            resolve("law", "both")
        # the others still resolve, a misspelt name says so, cpf plugins lists the ambiguous one on its line
        assert resolve("law", "literal")[1].builtin
        with pytest.raises(ValueError, match=r"no law 'nosuch' \(installed: both, corrected, literal"):
            resolve("law", "nosuch")
        assert re.search(r"^  both +does not load: 'both' is declared by other", plugins_text(), flags=re.M)
    finally:
        resolve.cache_clear()


class _Plain:
    def __init__(self, gain: float = 0.2) -> None:
        self.gain = gain

    def correction(self, gamma: float, gamma_dot: float, neighbours: object, gains: CoordinationGains) -> float:
        return 0.0


class _Due:
    def __init__(self, value: object) -> None:
        self.value = value

    def due(self, t: float, dt: float, now: object, last: object) -> object:
        return self.value


def test_what_an_extension_gives_is_read_as_its_interface_says():
    """Found by a new user: a plain class was refused with pydantic's advice about arbitrary types; a law returning
    numpy's int64 0 was 'not a finite number' while int 0 passed; a trigger's due() returning "yes" or None was taken
    as True or False; a missing member was not named."""
    _, _, problems = instantiate("law", f"{__name__}:_Plain", {})
    plain = "is not a dataclass or a pydantic model (its fields are its options): decorate it with @dataclass"
    assert problems == [(None, f"{__name__}:_Plain {plain}(frozen=True)")]
    assert instantiate("law", f"{SAMPLES}:NoCorrection", {})[2][0][1].endswith("(CoordinationLaw): no correction")
    law = Guarded(None, "law x")
    assert [law._finite(v) for v in (np.int64(0), np.float32(1.5), 2)] == [0.0, 1.5, 2.0]
    for bad in (True, np.bool_(False), "1"):
        with pytest.raises(FloatingPointError, match="not a finite number"):
            law._finite(bad)
    assert Guarded(_Due(np.bool_(True)), "t").due(0.0, 0.1, None, None) is True  # type: ignore[arg-type]
    for answer in ("yes", None, 1):
        with pytest.raises(FloatingPointError, match=r"transmission x due\(\) returned .*, not True or False"):
            Guarded(_Due(answer), "transmission x").due(0.0, 0.1, None, None)  # type: ignore[arg-type]

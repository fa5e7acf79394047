"""cpf.run, cpf.load and cpf.sweep given arguments of the wrong type: one line naming the argument, what it got and
what it takes (found by a new user: a str of faults split into characters, AttributeError, TypeError from pathlib).
Every one is refused before anything runs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cpf
from cpf.inputs import param_specs
from tests.conftest import CONFIGS, shortened

PAPER = CONFIGS / "paper.toml"
api: Any = cpf  # called with what its type hints refuse, as a user may
FAULTS = "faults: a list of --fault specs ('kind=blackout,start=5') or dicts ({'kind': 'blackout', 'start': 5}), got "
PARAMS = "params: a dict of KEY: values ({'comms.loss': [0.1, 0.2]}, or '0:0.8:0.1' as --param takes it), got "
SCENARIO = "scenario: a path (str or Path), TOML text (a str with a line break) or a dict of the file's tables, got "


@pytest.mark.parametrize(
    ("call", "said"),
    [
        (lambda: api.run(PAPER, faults="kind=blackout,start=5"), FAULTS + "'kind=blackout,start=5'"),
        (lambda: api.run(PAPER, faults={"kind": "blackout", "start": 5}), FAULTS + "{'kind': 'blackout', 'start': 5}"),
        (lambda: api.run(PAPER, faults=[3]), FAULTS + "[3]"),
        (lambda: api.run(PAPER, set="comms.loss=0.1"),
         "set: a dict of KEY: VALUE or a list of 'KEY=VALUE' strings, got 'comms.loss=0.1'"),
        (lambda: api.run(PAPER, options="--no-foxglove"),
         "options: a list of cpf run's options as strings (['--no-foxglove']), got '--no-foxglove'"),
        (lambda: api.run(b"paper.toml"), SCENARIO + "b'paper.toml'"),
        (lambda: api.run(3), SCENARIO + "3"),
        (lambda: api.run(None), SCENARIO + "None"),
        (lambda: api.run(""), SCENARIO + "''"),
        (lambda: api.run(PAPER, out=3), "out: a path (str or Path), or None, got 3"),
        (lambda: api.sweep(PAPER, params=["comms.loss=0.1"]), PARAMS + "['comms.loss=0.1']"),
        (lambda: api.sweep(PAPER, params="comms.loss=0.1"), PARAMS + "'comms.loss=0.1'"),
        (lambda: api.sweep(PAPER, params={"comms.loss": None}),
         "params: comms.loss: a value, a list of values or a --param text ('0:0.8:0.1'), got None"),
        (lambda: api.sweep(None, params={"comms.loss": [0.1]}), SCENARIO + "None"),
        (lambda: api.sweep(PAPER, params={"comms.loss": [0.1]}, out=2.5),
         "out: a path (str or Path), or None, got 2.5"),
    ],
    ids=["faults-str", "faults-dict", "faults-int", "set-str", "options-str", "run-bytes", "run-int", "run-none",
         "run-empty", "run-out", "params-list", "params-str", "params-none", "sweep-none", "sweep-out"],
)  # fmt: skip
def test_a_wrong_type_is_one_line_naming_the_argument(call, said, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # taken for a path, a wrong out made a sweep's directory where the tests ran
    with pytest.raises(cpf.ScenarioError) as caught:
        call()
    assert caught.value.errors == [said]


@pytest.mark.parametrize("given", [None, "", 3, b"run.mcap"])
def test_load_refuses_what_is_not_a_path(given):
    with pytest.raises(cpf.LogError) as caught:
        api.load(given)
    assert caught.value.errors == [f"path: a path (str or Path) of a log, got {given!r}"]


def test_a_swept_value_alone_is_a_list_of_one():
    """{"comms.loss": 0.1} raised TypeError ('float' object is not iterable): one value, as a list of it would be."""
    assert param_specs({"comms.loss": 0.1, "coordination.law": "corrected", "k": [1, 2]}) == [
        "comms.loss=0.1", "coordination.law=corrected", "k=1,2"
    ]  # fmt: skip
    assert param_specs({"comms.loss_model_options": {"p": 0.1}}) == ["comms.loss_model_options={p = 0.1}"]
    assert param_specs({"comms.loss": (0.1, 0.2)}) == ["comms.loss=0.1,0.2"]
    assert param_specs({"comms.loss": np.array(0.1)}) == ["comms.loss=0.1"]  # a 0-d array: TypeError (a review)


def test_paths_may_be_str_or_path(tmp_path):
    """What is refused above is not what a path is: a str and a Path both run (a 1 s run)."""
    short = tmp_path / "short.toml"
    short.write_text(shortened(PAPER.read_text(), 1.0))
    for given in (short, str(short)):
        assert cpf.run(given, out=Path(tmp_path / "r.mcap"), progress=False).states.t.max() == pytest.approx(0.9)

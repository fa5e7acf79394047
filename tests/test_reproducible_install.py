"""Reproducible installs (issue 28): requirements.lock pins every dependency pyproject.toml names (what `make`
installs, refreshed by `make lock`), and `cpf resim` warns when the log was made with other versions."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from supervisor.engine.resim import version_changes

ROOT = Path(__file__).resolve().parent.parent
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*")


def _canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def test_the_lock_pins_every_dependency_pyproject_names():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = list(project["dependencies"]) + [d for extra in project["optional-dependencies"].values() for d in extra]
    names = {_canonical(m.group(0)) for d in wanted if (m := NAME.match(d))}
    pinned = {}
    for line in (ROOT / "requirements.lock").read_text().splitlines():
        if "==" in line and not line.startswith((" ", "#")):
            name, _, version = line.partition("==")
            pinned[_canonical(name)] = version.split(";")[0].strip()
    missing = sorted(names - set(pinned))
    assert not missing, f"requirements.lock lacks {missing}: run `make lock`"
    assert all(re.fullmatch(r"[0-9][0-9A-Za-z.+!-]*", v) for v in pinned.values())  # exact versions, not ranges


def test_resim_says_which_versions_differ_from_the_logs():
    import numpy

    assert version_changes({"numpy": numpy.__version__}) == []
    assert version_changes({"numpy": "0.0.1", "no-such-package": "1.0"}) == [
        "no-such-package 1.0 -> none",
        f"numpy 0.0.1 -> {numpy.__version__}",
    ]

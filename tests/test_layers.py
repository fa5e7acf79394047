"""comms is the lower layer: no comms module imports vehicles or supervisor, not even inside a function.

`make lint` checks the same with import-linter (pyproject.toml [tool.importlinter]); this test reads the sources
itself, so it also holds where lint-imports is not run, and names the offending line.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

COMMS = Path(__file__).resolve().parent.parent / "comms"
UPPER = ("vehicles", "supervisor")


def imported_modules(source: str) -> list[tuple[int, str]]:
    """(line, module) of every import statement in a module, at any depth."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
    return found


def upward(source: str) -> list[str]:
    return [f"line {line}: {module}" for line, module in imported_modules(source) if module.split(".")[0] in UPPER]


@pytest.mark.parametrize("path", sorted(COMMS.glob("*.py")), ids=lambda p: p.name)
def test_no_comms_module_imports_an_upper_layer(path: Path) -> None:
    assert upward(path.read_text()) == []


def test_the_check_sees_imports_at_any_depth() -> None:
    source = "import numpy\nfrom comms.records.records import Heard\n\ndef f():\n    from vehicles.agent import step\n"
    assert upward(source) == ["line 5: vehicles.agent"]
    assert upward("import supervisor.cli as cli\n") == ["line 1: supervisor.cli"]

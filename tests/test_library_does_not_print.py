"""Only the command line talks to the user: the engines, the plan and the vehicles raise or log, never print."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
LIBRARY = [REPO / "cpf", REPO / "supervisor" / "engine", REPO / "supervisor" / "plan", REPO / "vehicles"]


def _prints(path: Path) -> list[int]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    calls = (n for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name))
    return [n.lineno for n in calls if n.func.id == "print"]  # type: ignore[attr-defined]


@pytest.mark.parametrize("path", sorted(p for d in LIBRARY for p in d.glob("*.py")), ids=lambda p: p.name)
def test_no_print_in_library_code(path: Path) -> None:
    assert _prints(path) == [], f"{path.relative_to(REPO)} prints (lines {_prints(path)}): log instead"

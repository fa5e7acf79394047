"""ARCHITECTURE.md stays true: every file, module, name and README section it mentions exists."""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TEXT = (ROOT / "ARCHITECTURE.md").read_text(encoding="utf-8")
PACKAGES = ("cpf", "supervisor", "comms", "vehicles", "numerics")


def _sources() -> list[Path]:
    return sorted(path for package in PACKAGES for path in (ROOT / package).rglob("*.py"))


def _defined() -> set[str]:
    """Every name a module, class or function of the packages defines, and every module and package name."""
    names = {path.stem for path in _sources()} | {path.parent.name for path in _sources()}
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names.add(node.name)
            elif isinstance(node, ast.Assign | ast.AnnAssign):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                names |= {target.id for target in targets if isinstance(target, ast.Name)}
    return names


def test_every_file_it_names_exists():
    files = set(re.findall(r"[\w./-]*\w\.(?:py|toml|md)\b", TEXT))
    assert len(files) > 20
    everywhere = {path.name for path in ROOT.rglob("*") if ".venv" not in path.parts}
    missing = [f for f in files if not (ROOT / f).exists() and ("/" in f or f not in everywhere)]
    assert missing == []


def test_every_folder_it_names_exists():
    folders = set(re.findall(r"`((?:supervisor|comms|vehicles)/[\w/]*)/`", TEXT))
    assert folders and [f for f in folders if not (ROOT / f).is_dir()] == []


def test_every_dotted_module_name_resolves():
    dotted = set(re.findall(r"\b(?:supervisor|comms|vehicles)(?:\.\w+)+", TEXT))
    assert dotted
    unresolved = []
    for name in dotted:
        parts = name.split(".")
        for cut in range(len(parts), 0, -1):  # the longest importable prefix, then attributes
            try:
                obj: object = importlib.import_module(".".join(parts[:cut]))
                break
            except ModuleNotFoundError:
                continue
        else:
            unresolved.append(name)
            continue
        for attribute in parts[cut:]:
            if not hasattr(obj, attribute):
                unresolved.append(name)
                break
            obj = getattr(obj, attribute)
    assert unresolved == []


def test_every_name_in_backticks_is_defined():
    quoted = set(re.findall(r"`([A-Za-z_]\w*)`", TEXT))
    assert len(quoted) > 10
    assert sorted(quoted - _defined() - {"Figure"}) == []  # Figure: matplotlib's


def test_every_readme_section_it_links_exists():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    anchors = {
        re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        for heading in re.findall(r"^#+ (.+)$", readme, re.M)
    }
    links = re.findall(r"README\.md#([\w-]+)", TEXT)
    assert links and [link for link in links if link not in anchors] == []

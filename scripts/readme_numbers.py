"""Rewrite the README's example outputs from the current code: `make readme` (or `python scripts/readme_numbers.py`).

Each block between `<!-- begin: cpf run ARGS -->` and `<!-- end -->` is replaced by a fenced block holding what
`cpf run ARGS --quiet` prints now. tests/test_readme.py checks the paper block's deterministic lines against a fresh
run, so a change of the code that changes the numbers fails there until this script is run.
"""

from __future__ import annotations

import argparse
import re
import shlex
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
BLOCK = re.compile(r"(<!-- begin: (cpf run [^>]*?) -->\n)(.*?)(<!-- end -->)", re.DOTALL)


def blocks(text: str) -> list[tuple[str, str]]:
    """(command, content) of every generated block in text."""
    return [(m.group(2), m.group(3)) for m in BLOCK.finditer(text)]


def rewrite(text: str, run: Callable[[str], str]) -> str:
    """text with every block's content replaced by run(command) in a fenced block."""

    def replace(match: re.Match[str]) -> str:
        output = run(match.group(2)).rstrip("\n")
        return f"{match.group(1)}```\n{output}\n```\n{match.group(4)}"

    return BLOCK.sub(replace, text)


def run_cpf(command: str) -> str:
    """What `command` (a `cpf run ...` line) prints, without its progress line; raises if it fails."""
    args = shlex.split(command)[1:]
    done = subprocess.run(
        [sys.executable, "-m", "supervisor.cli", *args, "--quiet"],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    if done.returncode != 0:
        raise SystemExit(f"readme_numbers: `{command}` failed ({done.returncode}): {done.stderr.strip()}")
    return done.stdout


def main(argv: list[str] | None = None) -> int:
    # No options, but --help says what it does and an unknown one is refused: `--help` ran both Zenoh runs and
    # rewrote the README (a helper's note).
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args(argv)
    text = README.read_text(encoding="utf-8")
    found = blocks(text)
    if not found:
        raise SystemExit(f"readme_numbers: no `<!-- begin: cpf run ... -->` block in {README}")
    for command, _ in found:
        print(f"readme_numbers: {command}", file=sys.stderr)
    README.write_text(rewrite(text, run_cpf), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())

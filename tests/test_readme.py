"""The README says what the code does: its example output is the current code's, its command list is complete."""

from __future__ import annotations

import argparse
import re

import pytest

from supervisor.cli import _parser, main
from tests.conftest import ROOT
from tests.procs import script

README = (ROOT / "README.md").read_text(encoding="utf-8")
PAPER_RUN = "cpf run configs/paper.toml --out runs/paper/run.mcap"
REGENERATE = "the README's numbers are not the code's: run `make readme` (scripts/readme_numbers.py) and commit"


def _section(title: str) -> str:
    return README.split(f"\n## {title}\n", 1)[1].split("\n## ", 1)[0]


def test_the_paper_block_is_what_the_current_code_prints(tmp_path, capsys):
    blocks = dict(script("readme_numbers").blocks(README))
    shown = blocks[PAPER_RUN].strip().removeprefix("```").removesuffix("```").strip().splitlines()
    code = main(["run", "configs/paper.toml", "--engine", "inprocess", "--quiet", "--out", str(tmp_path / "r.mcap")])
    fresh = capsys.readouterr().out.splitlines()
    assert code == 0
    # The first line holds the engine, the wall time and the message count: the machine's, not the model's.
    assert re.match(r"paper: 3 vehicles, \w+ engine, 400 s simulated in ", shown[0])
    assert shown[1:] == fresh[1:], REGENERATE


def test_the_script_rewrites_every_block_and_nothing_else():
    numbers = script("readme_numbers")
    text = "intro\n<!-- begin: cpf run a.toml -->\n```\nold\n```\n<!-- end -->\nmiddle\n"
    text += "<!-- begin: cpf run b.toml --set x=1 -->\n<!-- end -->\nend\n"
    out = numbers.rewrite(text, lambda command: f"ran {command}\nline 2\n")
    assert out == (
        "intro\n<!-- begin: cpf run a.toml -->\n```\nran cpf run a.toml\nline 2\n```\n<!-- end -->\nmiddle\n"
        "<!-- begin: cpf run b.toml --set x=1 -->\n```\nran cpf run b.toml --set x=1\nline 2\n```\n<!-- end -->\nend\n"
    )
    assert next(command for command, _ in numbers.blocks(README)) == PAPER_RUN


def test_the_command_line_section_lists_every_command():
    action = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    section = _section("The command line")
    missing = [name for name in action.choices if not re.search(rf"^cpf {name}\b", section, re.MULTILINE)]
    assert not missing, f"README's command-line section does not list {missing}"


@pytest.mark.parametrize("target", ["docs/scenario-reference.md", "configs/examples/"])
def test_the_readme_links_the_reference_and_the_examples(target):
    assert target in README and (ROOT / target).exists()


def test_the_script_says_what_it_does_and_refuses_what_it_does_not_know(capsys):
    """`--help` ran both Zenoh runs and rewrote the README: it prints the script's doc now, touching nothing."""
    numbers = script("readme_numbers")
    before = (ROOT / "README.md").read_bytes()
    for argv, code in ((["--help"], 0), (["--dry-run"], 2)):
        with pytest.raises(SystemExit) as stop:
            numbers.main(argv)
        assert stop.value.code == code
    assert "Rewrite the README's example outputs" in capsys.readouterr().out
    assert (ROOT / "README.md").read_bytes() == before

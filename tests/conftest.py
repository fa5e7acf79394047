"""Shared fixtures: the repository's scenario files, and shortened variants of them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"


def shortened(text: str, duration: float) -> str:
    """A scenario text with its duration replaced."""
    return re.sub(r"(?m)^duration = .*$", f"duration = {duration}", text, count=1)


@pytest.fixture
def paper_text() -> str:
    return (CONFIGS / "paper.toml").read_text()

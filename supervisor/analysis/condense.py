"""How the run summary stays readable for a large fleet: a table with a row per vehicle or per link prints every row
up to MAX_ROWS, and beyond that the worst few and a total (`cpf run --metrics FILE` keeps every row)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TypeVar

MAX_ROWS = 24  # rows a table prints in full (the paper's 3 AUVs have 4 links; a ring of 12, 24)
SHOWN = 10  # rows kept of a longer table: those its reader would look for first

T = TypeVar("T")


def first_looked_at(items: Sequence[T], worst_first: Callable[[T], float]) -> list[T]:
    """Every item up to MAX_ROWS; more, the SHOWN that sort first by worst_first (ties in the items' order)."""
    if len(items) <= MAX_ROWS:
        return list(items)
    return sorted(items, key=worst_first)[:SHOWN]


def delivered_share(sent: int, delivered: int) -> float:
    """The share of a link's packets that arrived; 1 for a link that sent none (none was lost)."""
    return delivered / sent if sent else 1.0


def spread(values: Sequence[float], fmt: str) -> str:
    """The values of a long row as min-max (and how many), NaNs (a vehicle down all the phase) left out."""
    finite = [v for v in values if not math.isnan(v)]
    if not finite:
        return f"- ({len(values)} vehicles)"
    return f"{min(finite):{fmt}} to {max(finite):{fmt}} over {len(values)} vehicles"


def kept_note(shown: int, total: int, which: str) -> str:
    """which: the rows and why these, e.g. 'links that delivered least'."""
    return f"(above: the {shown} of {total} {which}; `cpf run --metrics FILE` writes every one)"

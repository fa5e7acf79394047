"""Legends that fit a run figure at any fleet size (the rules: supervisor.analysis.figures' docstring): inside the
axes while short, beside them in columns when long, and past LEGEND_VEHICLES_MAX vehicles a colour bar from hue to
vehicle in place of their entries."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.legend import Legend

LEGEND_INSIDE_MAX = 6
LEGEND_ROWS_MAX = 16
LEGEND_VEHICLES_MAX = 4 * LEGEND_ROWS_MAX  # vehicles named one by one in a legend; more: a colour bar
VEHICLE = "cpf-vehicle"  # the gid of an artist drawn for one vehicle in its colour (place_legend)
KEY_TICKS = 6  # vehicles named on a colour bar


def place_legend(ax: Axes, fontsize: str = "small") -> Legend | None:
    """A legend that neither hides the data nor leaves the image: inside while short, beside the axes in columns
    when long (constrained layout makes room for it); none when nothing is labelled (an empty legend warns). More
    than LEGEND_VEHICLES_MAX vehicles' lines: a colour bar names them (colour_key), the legend the rest."""
    entries = list(zip(*ax.get_legend_handles_labels(), strict=True))
    fleet = [(h, label) for h, label in entries if h.get_gid() == VEHICLE]
    if len(fleet) > LEGEND_VEHICLES_MAX:
        colour_key(ax, [h.get_color() for h, _ in fleet], [label for _, label in fleet])  # type: ignore[attr-defined]
        entries = [(h, label) for h, label in entries if h.get_gid() != VEHICLE]
    handles, labels = [h for h, _ in entries], [label for _, label in entries]
    count = len(handles)
    if count == 0:
        return None
    if count <= LEGEND_INSIDE_MAX:
        return ax.legend(handles, labels, loc="best", fontsize=fontsize)
    columns = math.ceil(count / LEGEND_ROWS_MAX)
    return ax.legend(
        handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, ncols=columns,
        fontsize=fontsize,
    )  # fmt: skip


def colour_key(
    ax: Axes, colours: Sequence[Any], names: Sequence[str], figure: Figure | None = None, inside: bool = False
) -> None:
    """A colour bar beside ax with one band per vehicle in its colour, KEY_TICKS of them named (figure: the figure
    to hold it, if not ax's); inside: drawn in ax itself (an axes made for it, on a figure without a layout
    engine)."""
    n = len(colours)
    mappable = ScalarMappable(BoundaryNorm(np.arange(n + 1), n), ListedColormap(list(colours)))
    marks = sorted({round(x) for x in np.linspace(0, n - 1, KEY_TICKS)})
    holder = figure or ax.get_figure()
    assert holder is not None  # ax is on a figure
    ticks = [m + 0.5 for m in marks]
    if inside:
        bar = holder.colorbar(mappable, cax=ax, ticks=ticks)
    else:
        bar = holder.colorbar(mappable, ax=ax, ticks=ticks, fraction=0.04)
    bar.ax.set_yticklabels([names[m] for m in marks], fontsize="small")
    bar.ax.minorticks_off()
    bar.set_label(f"{n} vehicles, one hue each")

"""Figures of alike panels on a fixed grid: the report's stacked time series (a vehicle's velocities, the channel's
panel per link or per vehicle).

Not constrained layout, which the report's other figures use: alike panels fit the same room, and matplotlib draws a
figure with a layout engine twice when it saves it (once to lay it out), half the cost of drawing it (an 8-vehicle
run's 20-panel figures: 2.3 -> 1.1 s each, of a report's 9 s).
"""

from __future__ import annotations

from matplotlib.axes import Axes
from matplotlib.figure import Figure

# in: left (tick labels and the y label), right, bottom (tick labels and the x label), top (the figure's title and
# the first row's panel title), between rows (a panel's title), between columns (the right column's y label)
MARGINS = (0.85, 0.25, 0.6, 0.85, 0.45, 0.9)
UNTITLED = 0.3  # in less at the top and between rows when the panels have no title of their own
TITLE_FROM_TOP = 0.15  # in: the figure's title below its top edge


def panel_grid(
    width: float, height: float, nrows: int, ncols: int, title: str, sharey: bool = False, titled: bool = True
) -> tuple[Figure, list[Axes]]:
    """A width x height in figure of nrows x ncols panels sharing the time axis, row by row, under `title`; titled:
    whether each panel gets a title of its own (room is left for it)."""
    fig = Figure(figsize=(width, height))
    left, right, bottom, top, between_rows, between_columns = MARGINS
    if not titled:
        top, between_rows = top - UNTITLED, between_rows - UNTITLED
    panel_w = (width - left - right - (ncols - 1) * between_columns) / ncols
    panel_h = (height - bottom - top - (nrows - 1) * between_rows) / nrows
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=bottom / height, top=1 - top / height,
                        wspace=between_columns / panel_w, hspace=between_rows / panel_h)  # fmt: skip
    grid = fig.subplots(nrows, ncols, sharex=True, sharey=sharey, squeeze=False)
    fig.suptitle(title, y=1 - TITLE_FROM_TOP / height, va="top")
    return fig, list(grid.flat)

"""Figures of a recorded run, analogous to Figs. 3-8 of Aguiar & Pascoal's coordinated path-following paper, and
of its acoustic channel.

The run comes from ``load_run`` (supervisor.analysis.rundata, re-exported here).
``write_figures`` renders the PNGs (the channel's in analysis.report_comms); ``write_report`` adds metrics.json
(supervisor.analysis.metrics). Figures are built on ``matplotlib.figure.Figure`` directly (Agg canvas, no pyplot), so
nothing touches global plotting state and the module is safe to use from tests and threads.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from supervisor.analysis.condense import first_looked_at
from supervisor.analysis.drawing import draw, workers
from supervisor.analysis.figures import (  # colour, finish_time_axes, new_figure: for report_comms
    DPI,
    colour,
    fig_coordination_errors,
    fig_gamma_dot,
    fig_path_following_errors,
    fig_trajectories,
    fig_velocities,
    finish_time_axes,
    new_figure,
)
from supervisor.analysis.rundata import (
    AgeSeries,
    FaultInterval,
    LinkLog,
    RunData,
    VehicleSeries,
    load_run,
    read_for_report,
)
from supervisor.analysis.tx_books import BooksLog

__all__ = [
    "DPI",
    "AgeSeries",
    "FaultInterval",
    "LinkLog",
    "RunData",
    "VehicleSeries",
    "colour",
    "figure_builders",
    "finish_time_axes",
    "load_run",
    "new_figure",
    "write_figures",
    "write_report",
]

METRICS_FILE = "metrics.json"


def write_report(log: Path, out_dir: Path, read: tuple[RunData, BooksLog] | None = None) -> list[Path]:
    """Every figure of a recorded run and its metrics (metrics.json) into out_dir; returns the paths written.
    read: what read_for_report(log) gives, if already read (cpf report reads it aside while this module loads)."""
    from supervisor.analysis.metrics import report_metrics

    run, on_the_books = read if read is not None else read_for_report(log)
    paths = write_figures(run, out_dir)
    metrics = out_dir / METRICS_FILE
    numbers = report_metrics(log, run, on_the_books)  # the API's Run.summary too
    metrics.write_text(json.dumps(numbers, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    return [*paths, metrics]


def write_figures(run: RunData, out_dir: Path) -> list[Path]:
    """Render every figure of the run (figure_builders) into out_dir as PNG; returns the paths written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = figure_builders(run)
    return draw(run, figures, out_dir, workers(len(figures)))


def figure_builders(run: RunData) -> list[tuple[str, Callable[[RunData], Figure]]]:
    """(name, builder) of every figure of the run, in the report's order (the PNG is <name>.png): the paper's
    analogues (fig3-fig6, gamma_dot: analysis.figures, which says how each adapts to the fleet and the run), then
    the channel's (comms_*: supervisor.analysis.report_comms)."""
    from supervisor.analysis.figures_current import fig_current_estimates, has_current_estimate
    from supervisor.analysis.figures_nav import fig_navigation_errors, has_navigation
    from supervisor.analysis.report_comms import comms_figures  # it builds on this module's data and helpers

    figures: list[tuple[str, Callable[[RunData], Figure]]] = [
        ("fig3_trajectories", fig_trajectories),
        ("fig4_path_following_errors", fig_path_following_errors),
        ("fig5_coordination_errors", fig_coordination_errors),
    ]
    figures += [(f"fig6_velocities_auv{v}", _velocities_figure(v)) for v in velocity_figure_vehicles(run)]
    figures.append(("gamma_dot", fig_gamma_dot))
    if has_navigation(run):
        figures.append(("navigation_errors", fig_navigation_errors))
    if has_current_estimate(run):
        figures.append(("current_estimates", fig_current_estimates))
    return figures + [(name.removesuffix(".png"), build) for name, build in comms_figures(run)]


def velocity_figure_vehicles(run: RunData) -> list[int]:
    """The vehicles that get a velocity figure (Fig. 6) each: every one up to MAX_ROWS, else the SHOWN that strayed
    furthest from their paths (supervisor.analysis.condense: 1000 figures took longer than the run)."""
    worst = {v: float(np.nanmax(s.error_norm, initial=0.0)) for v, s in run.vehicles.items()}
    return sorted(first_looked_at(list(run.vehicles), lambda v: -worst[v]))


def _velocities_figure(vehicle: int) -> Callable[[RunData], Figure]:
    def build(run: RunData) -> Figure:
        return fig_velocities(run, run.vehicles[vehicle])

    return build

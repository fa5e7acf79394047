"""Figures of the acoustic channel of a recorded run: packets per directed link, delivery delays, how old each
vehicle's neighbour estimates got, and the connectivity the channel delivered.

Everything comes from the log (analysis.report.load_run): the broker's link events, the vehicles' estimate ages
and the broker's stats snapshots. Same conventions as analysis.report: Figure objects on the Agg canvas, fault
intervals shaded on every time axis.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import LogLocator

from comms.broker.stats import clamp_lambda2
from comms.records.graph import algebraic_connectivity, laplacian
from supervisor.analysis.condense import SHOWN, delivered_share, first_looked_at
from supervisor.analysis.figures import colour, finish_time_axes, new_figure, vehicle_colours
from supervisor.analysis.legends import LEGEND_VEHICLES_MAX, colour_key
from supervisor.analysis.panels import panel_grid
from supervisor.analysis.rundata import AgeSeries, Array, LinkLog, RunData

__all__ = ["comms_figures"]

PANEL_HEIGHT = 1.9  # in per subplot row
KEY_ROOM = 1.6  # in of right margin for a colour bar and its names
MAX_ROWS_ONE_COLUMN = 4
DELAY_BINS = 40
SKEWED_COUNTS = 20.0  # tallest / smallest non-empty bar above which the count axis is logarithmic
MIN_DELAY_SPAN = 1e-3
HEADROOM = 1.15  # y-axis top over the largest value  # s: a histogram of (nearly) equal delays still gets visible bins
KIND_STYLE = {  # (colour, line width) per event kind in the packet figure
    "sent": ("tab:blue", 2.4),
    "delivered": ("tab:green", 1.2),
    "dropped": ("k", 1.2),
}

FigureBuilder = Callable[[RunData], Figure]


def comms_figures(run: RunData) -> list[tuple[str, FigureBuilder]]:
    """(file name, builder) of each channel figure that has data: packets and delays only if the log holds link
    events, ages only if it holds estimate ages, lambda_2 only if it holds stats snapshots (a resim log has states
    alone: its empty panels were drawn all the same)."""
    figures: list[tuple[str, FigureBuilder]] = []
    if run.links:
        figures += [("comms_packets.png", fig_packets), ("comms_delay_histogram.png", fig_delays)]
    if run.estimate_ages:
        figures.append(("comms_estimate_age.png", fig_estimate_age))
    if run.stats:
        figures.append(("comms_lambda2.png", fig_lambda2))
    return figures


def _panels(n: int, title: str, sharey: bool = False) -> tuple[Figure, list[Axes]]:
    """A figure of n subplots (one column up to four, then two), shared time axis; at least one subplot."""
    n = max(n, 1)
    ncols = 1 if n <= MAX_ROWS_ONE_COLUMN else 2
    nrows = math.ceil(n / ncols)
    fig, axes = panel_grid(9.0 if ncols == 1 else 12.0, 1.2 + PANEL_HEIGHT * nrows, nrows, ncols, title, sharey)
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, axes[:n]


def _empty(ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.4")
    ax.set_xticks([])
    ax.set_yticks([])


def _only_bottom_xlabels(axes: Sequence[Axes]) -> None:
    """Time labels only under the lowest panel of each column (which may stand above a hidden, unused one)."""
    spec = axes[0].get_subplotspec()
    ncols = spec.get_gridspec().ncols if spec is not None else 1
    for ax in axes[:-ncols]:
        ax.set_xlabel("")
    for ax in axes[-ncols:]:
        ax.tick_params(labelbottom=True)


def _drops(link: LinkLog) -> str:
    causes = link.dropped_by_cause()
    return ", ".join(f"{n} {cause}" for cause, n in sorted(causes.items())) or "none"


# --- packets ------------------------------------------------------------------------------------------------


def shown_links(run: RunData) -> tuple[list[LinkLog], str]:
    """The links a per-link figure draws, and what its title adds: every one up to MAX_ROWS, else the SHOWN that
    delivered the smallest share of what they sent (supervisor.analysis.condense; 2000 panels took minutes and
    showed nothing)."""
    links = list(run.links.values())
    shown = first_looked_at(links, lambda link: delivered_share(link.times("sent").size, link.times("delivered").size))
    return shown, f" (the {SHOWN} of {len(links)} links that delivered least)" if len(shown) < len(links) else ""


def fig_packets(run: RunData) -> Figure:
    """Per directed link: cumulative packets sent, delivered and dropped over time."""
    links, which = shown_links(run)
    fig, axes = _panels(len(links), f"Packets per directed link (cumulative): {run.name}{which}", sharey=True)
    if not run.links:
        _empty(axes[0], "no link events (cpf/comms/events) in this log")
        return fig
    for k, (ax, link) in enumerate(zip(axes, links, strict=False)):
        for kind, (c, width) in KIND_STYLE.items():
            _cumulative(ax, run, link.times(kind), c, width, kind if k == 0 else "_nolegend_")
        sent, delivered = link.times("sent").size, link.times("delivered").size
        ax.set_title(f"{link.name}: {sent} sent, {delivered} delivered, dropped: {_drops(link)}", fontsize="medium")
        finish_time_axes(ax, run, "packets")
        legend = ax.get_legend()
        if k > 0 and legend is not None:
            legend.remove()  # one legend, on the first panel, says it for all
    _only_bottom_xlabels(axes)
    return fig


def _cumulative(ax: Axes, run: RunData, times: Array, c: str, width: float, label: str) -> None:
    """A staircase rising by one at each time, from 0 at the start of the run to the end of the run."""
    start, end = run.t_range
    first, last = (float(times[0]), float(times[-1])) if times.size else (start, end)
    t = np.concatenate(([min(start, first)], times, [max(end, last)]))
    count = np.concatenate(([0], np.arange(1, times.size + 1), [times.size]))
    ax.step(t, count, where="post", color=c, lw=width, alpha=0.8, label=label)


# --- delays -------------------------------------------------------------------------------------------------


def fig_delays(run: RunData) -> Figure:
    """Histogram of the delivery delay (transmission to arrival) of every delivered packet, one panel per link."""
    links, which = shown_links(run)
    fig, axes = _panels(len(links), f"Delivery delays per directed link: {run.name}{which}")
    delays = [link.delays for link in links]
    if not any(d.size for d in delays):
        _empty(axes[0], "no delivered packets in this log")
        return fig
    bins = _delay_bins(np.concatenate(delays))
    for k, (ax, link, d) in enumerate(zip(axes, links, delays, strict=False)):
        if d.size:
            # stepfilled: one polygon per panel, not a patch per bin (20 panels of 40 bins: 0.9 s of CPU less)
            counts, _, _ = ax.hist(d, bins=bins.tolist(), color=colour(k), alpha=0.8, histtype="stepfilled")
            _log_if_skewed(ax, np.asarray(counts, dtype=float))
            ax.set_title(
                f"{link.name}: {d.size} delivered, delay {d.min():.3f}-{d.max():.3f} s, mean {d.mean():.3f} s",
                fontsize="medium",
            )
        else:
            ax.set_title(f"{link.name}: nothing delivered", fontsize="medium")
        ax.set_xlabel("delivery delay [s] (transmission to arrival)")
        ax.grid(True, alpha=0.3)
    _only_bottom_xlabels(axes)
    return fig


def _log_if_skewed(ax: Axes, counts: Array) -> None:
    """A log count axis when a few stray packets would not show next to the tallest bar."""
    nonzero = counts[counts > 0]
    if nonzero.size and nonzero.max() > SKEWED_COUNTS * nonzero.min():
        ax.set_yscale("log")
        # minor ticks at 2 and 5 only (labelled when the panel spans less than a decade): the default 2..9 cost
        # about 60 % of this figure's drawing time (8 vehicles, 16 panels: 9.5 -> 3.5 s)
        ax.yaxis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
        ax.set_ylabel("packets (log)")
    else:
        ax.set_ylabel("packets")


def _delay_bins(delays: Array) -> Array:
    low, high = float(delays.min()), float(delays.max())
    if high - low < MIN_DELAY_SPAN:
        middle = (low + high) / 2
        low, high = middle - MIN_DELAY_SPAN / 2, middle + MIN_DELAY_SPAN / 2
    return np.linspace(low, high, DELAY_BINS + 1)


# --- estimate ages ------------------------------------------------------------------------------------------


def fig_estimate_age(run: RunData) -> Figure:
    """Per vehicle: the age of its estimate of each neighbour over time (sawtooth: resets at each reception)."""
    holders, which = _shown_holders(run)
    fig, axes = _panels(len(holders), f"Age of each vehicle's neighbour estimates: {run.name}{which}", sharey=True)
    if not holders:
        _empty(axes[0], "no estimate ages (estimate_age of cpf/vehicle/<id>/state) in this log")
        return fig
    top = max(float(a.age.max()) for a in run.estimate_ages.values() if a.age.size) * HEADROOM or 1.0
    colours = vehicle_colours(run)
    mine = {holder: {n: ages for (n, h), ages in run.estimate_ages.items() if h == holder} for holder in holders}
    named = max(len(of) for of in mine.values()) <= LEGEND_VEHICLES_MAX  # else one colour bar for every panel
    for ax, holder in zip(axes, holders, strict=True):
        for neighbour, ages in mine[holder].items():
            _age_line(ax, neighbour, ages, colours.get(neighbour, "0.5"), named)
        ax.set_ylim(0.0, top)  # explicit: a constant age (ideal channel) would sit on the frame
        finish_time_axes(ax, run, "age [s]", f"AUV {holder}'s estimates")
    if not named:  # in a margin made for it: the panels are on a fixed grid (supervisor.analysis.panels)
        width = fig.get_figwidth()
        fig.subplots_adjust(right=1 - KEY_ROOM / width)
        key = fig.add_axes((1 - (KEY_ROOM - 0.25) / width, 0.1, 0.15 / width, 0.8))
        colour_key(key, list(colours.values()), [f"AUV {v}" for v in colours], inside=True)
    _only_bottom_xlabels(axes)
    return fig


def _shown_holders(run: RunData) -> tuple[list[int], str]:
    """The vehicles whose estimates get a panel: every one up to MAX_ROWS, else the SHOWN whose estimates got
    oldest (supervisor.analysis.condense)."""
    holders = sorted({holder for _, holder in run.estimate_ages})
    oldest: dict[int, float] = {}
    for (_, holder), ages in run.estimate_ages.items():
        if ages.age.size:
            oldest[holder] = max(oldest.get(holder, 0.0), float(ages.age.max()))
    chosen = sorted(first_looked_at(holders, lambda h: -oldest.get(h, 0.0)))
    which = (
        f" (the {SHOWN} of {len(holders)} vehicles whose estimates got oldest)" if len(chosen) < len(holders) else ""
    )
    return chosen, which


def _age_line(ax: Axes, neighbour: int, ages: AgeSeries, c: Any, named: bool) -> None:
    """In the neighbour's colour of every figure, named in the legend (named) or by the figure's colour bar."""
    label = f"of AUV {neighbour} (max {ages.age.max():.1f} s, mean {ages.age.mean():.1f} s)" if named else "_nolegend_"
    ax.plot(ages.t, ages.age, color=c, lw=1.2, label=label)


# --- connectivity -------------------------------------------------------------------------------------------


def fig_lambda2(run: RunData) -> Figure:
    """lambda_2 of the graph of pairs that delivered within the stats' horizon (the window, or longer when the
    vehicles transmit less often: supervisor.config.fleet.delivered_graph_horizon), per window, against the scenario
    graph's."""
    fig = new_figure()
    ax = fig.add_subplot()
    previous = -math.inf
    for k, snap in enumerate(run.stats):
        t, window, value = snap.t, snap.window, clamp_lambda2(snap.lambda2)
        start = max(t - window, previous)  # a final, partial window starts where the last one ended
        ax.hlines(
            value, start, t, color="tab:blue", lw=2.0, label="delivered graph, per window" if k == 0 else "_nolegend_"
        )
        previous = t
    values = np.array([clamp_lambda2(s.lambda2) for s in run.stats])  # an older log: -1e-17 for 0
    ends = np.array([s.t for s in run.stats])
    ax.plot(ends, values, "o", color="tab:blue", ms=3.5)
    nominal = _nominal_lambda2(run)
    ax.axhline(nominal, color="k", ls="--", lw=1.0, label=rf"scenario graph: $\lambda_2$ = {nominal:.3g}")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_ylim(-0.05 * max(nominal, 1.0), HEADROOM * max(nominal, float(values.max()), 1e-3))
    disconnected = int((values <= 0.0).sum())
    window = run.stats[0].window
    horizon = window if run.stats[0].horizon is None else run.stats[0].horizon
    counted = "in the window" if horizon <= window else f"in the last {horizon:g} s"
    title = (
        rf"Delivered-graph connectivity $\lambda_2$: {run.name}"
        f"\nper {window:g} s window (pairs that delivered {counted})\n{len(values)} windows: "
        f"min {values.min():.3g}, mean {values.mean():.3g}, {disconnected} disconnected ($\\lambda_2$ = 0)"
    )
    finish_time_axes(ax, run, r"$\lambda_2$ of the delivered graph", title)
    start, end = run.t_range
    ax.set_xlim(min(start, float(ends.min()) - window), max(end, float(ends.max())))
    return fig


def _nominal_lambda2(run: RunData) -> float:
    """lambda_2 of the scenario's communication graph (as the meta records it)."""
    ids = (list(run.meta.vehicles) if run.meta is not None else []) or sorted(run.vehicles)
    index = {v: i for i, v in enumerate(ids)}
    edges = [(index[i], index[j]) for i, j in run.edges if i in index and j in index]
    return clamp_lambda2(algebraic_connectivity(laplacian(len(ids), edges)))

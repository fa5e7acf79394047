"""Summary plots of a sweep: steady-state coordination error and packets against each swept parameter, the line the
median across seeds and the band the 10-90 % spread."""

from __future__ import annotations

from collections.abc import Sequence
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from supervisor.metrics import STEADY_STATE_WINDOW
from supervisor.sweep import Param

FLOOR = 1e-6  # log axes: errors below this are drawn at it


def plot_sweep(rows: Sequence[dict[str, Any]], params: Sequence[Param], out_dir: Path) -> list[Path]:
    paths = []
    for param in params:
        others = [p for p in params if p.key != param.key]
        fig = Figure(figsize=(16, 4.5), dpi=120)
        FigureCanvasAgg(fig)
        error_ax, resync_ax, packet_ax = fig.subplots(1, 3)
        for combo in product(*[[(p.key, v) for v in p.values] for p in others]):
            chosen = [r for r in rows if all(r.get(k) == v for k, v in combo)]
            label = ", ".join(f"{k.split('.')[-1]}={v}" for k, v in combo)
            _band(error_ax, chosen, param, "steady_coordination_error", label or "steady state", log=True)
            _band(resync_ax, chosen, param, "resync_time", label or "after the last fault", log=False)
            _band(packet_ax, chosen, param, "sent", f"sent {label}".strip(), log=False)
            _band(packet_ax, chosen, param, "delivered", f"delivered {label}".strip(), log=False)
        seeds = len({r["seed"] for r in rows})
        error_ax.set(
            xlabel=param.key, ylabel=f"max|gamma_i - gamma_j|, final {STEADY_STATE_WINDOW:.0f} s", yscale="log"
        )
        error_ax.set_title(f"Steady-state coordination error ({seeds} seeds: median, 10-90 %)")
        resync_ax.set(xlabel=param.key, ylabel="s (never: not drawn)")
        resync_ax.set_title("Coordination back below tolerance at")
        packet_ax.set(xlabel=param.key, ylabel="packets (all directed links)")
        packet_ax.set_title("Packets sent and delivered")
        for ax in (error_ax, resync_ax, packet_ax):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        path = out_dir / f"sweep_{param.key.replace('.', '_')}.png"
        fig.savefig(path)
        paths.append(path)
    return paths


def _band(ax: Axes, rows: Sequence[dict[str, Any]], param: Param, column: str, label: str, log: bool) -> None:
    xs = [v for v in param.values if any(r.get(param.key) == v for r in rows)]
    if not xs or not all(isinstance(x, int | float) for x in xs):
        return
    # A run that never got there (None) has no value to draw; the band shows the runs that did.
    values = [np.array([float(r[column]) for r in rows if r.get(param.key) == x and r[column] is not None]) for x in xs]
    keep = [i for i, v in enumerate(values) if len(v)]
    xs, values = [xs[i] for i in keep], [values[i] for i in keep]
    if not xs:
        return
    if log:
        values = [np.maximum(v, FLOOR) for v in values]
    median = [float(np.median(v)) for v in values]
    low = [float(np.percentile(v, 10)) for v in values]
    high = [float(np.percentile(v, 90)) for v in values]
    (line,) = ax.plot(xs, median, marker="o", label=label)
    ax.fill_between(xs, low, high, color=line.get_color(), alpha=0.2)

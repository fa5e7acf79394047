"""The navigation figure of a run with [navigation]: how far each vehicle's position estimate was from the truth.

Each vehicle's |p_hat - p| over time with the filter's own 1-sigma (the root of the trace of its position
covariance, dotted), and its position fixes marked: dots where one was fused, crosses where one was due but lost.
Absent for a run without navigation (its state messages carry no estimate).
"""

from __future__ import annotations

from matplotlib.figure import Figure

from supervisor.analysis.figures import finish_time_axes, new_figure, vehicle_colours
from supervisor.analysis.legends import VEHICLE
from supervisor.analysis.rundata import RunData

FIX, FIX_LOST = 1, 2  # nav_fix in a state message (vehicles.navigation)


def has_navigation(run: RunData) -> bool:
    return any(s.nav_error is not None for s in run.vehicles.values())


def fig_navigation_errors(run: RunData) -> Figure:
    """|p_hat_i - p_i| per vehicle, the filter's 1-sigma, and the fix instants."""
    fig = new_figure()
    ax = fig.add_subplot()
    for vehicle, c in vehicle_colours(run).items():
        s = run.vehicles[vehicle]
        if s.nav_error is None or s.nav_sigma is None or s.nav_fix is None:
            continue
        ax.plot(s.t, s.nav_error, color=c, lw=1.0, label=f"AUV {vehicle}", gid=VEHICLE)
        ax.plot(s.t, s.nav_sigma, color=c, lw=1.0, ls=":")
        fused, lost = s.nav_fix == FIX, s.nav_fix == FIX_LOST
        ax.plot(s.t[fused], s.nav_error[fused], "o", color=c, ms=3)
        ax.plot(s.t[lost], s.nav_error[lost], "x", color=c, ms=5)
    ax.plot([], [], "k:", label=r"filter $1\sigma$")
    ax.plot([], [], "ko", ms=3, ls="", label="fix fused")
    ax.plot([], [], "kx", ms=5, ls="", label="fix lost")
    ax.set_ylim(bottom=0.0)
    finish_time_axes(ax, run, r"$|\hat p_i - p_i|$ [m]", f"Navigation errors: {run.name}")
    return fig

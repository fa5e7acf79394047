"""The current figure of a run whose vehicles estimate the current (vehicles.current_observer): each vehicle's
estimate of the current's horizontal components over time, beside the current the scenario made (dashed, at the
vehicle's recorded depth). Absent for a run without the observer (its state messages carry no estimate)."""

from __future__ import annotations

from matplotlib.figure import Figure

from supervisor.analysis.figures import finish_time_axes, new_figure, vehicle_colours
from supervisor.analysis.legends import VEHICLE
from supervisor.analysis.metrics import run_scenario
from supervisor.analysis.rundata import RunData
from supervisor.config.plant import current_of
from vehicles.current import Current


def has_current_estimate(run: RunData) -> bool:
    return any(s.current_estimate is not None for s in run.vehicles.values())


def _true_current(run: RunData) -> Current | None:
    """The scenario's current, from the run's meta (None: still water, no meta, or a scenario this version cannot
    read)."""
    scenario = run_scenario(run)
    return None if scenario is None else current_of(scenario)


def fig_current_estimates(run: RunData) -> Figure:
    """x and y of each vehicle's current estimate, and the scenario's current where it was."""
    fig = new_figure()
    axes = fig.subplots(2, 1, sharex=True)
    truth = _true_current(run)
    for vehicle, c in vehicle_colours(run).items():
        s = run.vehicles[vehicle]
        if s.current_estimate is None:
            continue
        made = None if truth is None else [truth.velocity(t, z) for t, z in zip(s.t, s.position[:, 2], strict=True)]
        for axis, ax in enumerate(axes):
            named = {"label": f"AUV {vehicle}", "gid": VEHICLE} if axis == 0 else {}  # one key for both axes
            ax.plot(s.t, s.current_estimate[:, axis], color=c, lw=1.0, **named)
            if made is not None:
                ax.plot(s.t, [m[axis] for m in made], color=c, lw=1.0, ls="--")
    if truth is not None:
        axes[0].plot([], [], "k--", lw=1.0, label="the scenario's current")
    finish_time_axes(axes[0], run, r"$\hat v_{c,x}$ [m/s]", f"Current estimates: {run.name}")
    finish_time_axes(axes[1], run, r"$\hat v_{c,y}$ [m/s]", "")
    axes[0].set_xlabel("")  # the axes share t
    legend = axes[1].get_legend()
    if legend is not None:  # one legend for both
        legend.remove()
    return fig

"""Tests for the figures people read (analysis.figures through write_figures, supervisor.tools.sweep_plot through
plot_sweep): asserted on the matplotlib objects each figure was saved from, not on pixels.

Synthetic fleets: n vehicles on concentric circles (radius 10 + 5 i m), gammas converging to t from spread starts,
at a depth that varies by z_span; optionally one vehicle down (no states) over an interval, as after a kill.
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.text import Text

from supervisor.analysis import report as report_module
from supervisor.analysis.report import RunData, VehicleSeries, write_figures, write_report
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.tools.sweep import Param
from supervisor.tools.sweep_plot import plot_sweep
from tests.conftest import run_meta, shortened

STEP, DURATION, PERIOD = 0.5, 200.0, 300.0


def series(vehicle: int, z_span: float, down: tuple[float, float] | None) -> VehicleSeries:
    t = np.arange(0.0, DURATION + STEP / 2, STEP)
    if down is not None:
        t = t[(t < down[0]) | (t >= down[1])]
    gamma = t + (vehicle - 4.5) * 2.0 * np.exp(-t / 30.0)
    angle = 2.0 * math.pi * gamma / PERIOD
    radius = 10.0 + 5.0 * vehicle
    desired = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), -10.0 + z_span * np.sin(t / 20.0)])
    error = np.column_stack([np.exp(-t / 10.0), np.zeros_like(t), np.zeros_like(t)])
    ones = np.ones_like(t)
    return VehicleSeries(
        vehicle, t, gamma, ones, desired + error, np.column_stack([ones, 0 * t, 0 * t]), error,
        np.zeros((len(t), 4)), 0 * t, 0 * t,
    )  # fmt: skip


def fleet(
    n: int, z_span: float = 0.2, dimension: int = 3, down: dict[int, tuple[float, float]] | None = None
) -> RunData:
    down = down or {}
    meta = run_meta(scenario_name=f"fleet{n}", duration=DURATION, tube_radius=1.2,
                    scenario={"scenario": {"dimension": dimension}})  # fmt: skip
    vehicles = {v: series(v, z_span, down.get(v)) for v in range(1, n + 1)}
    return RunData(meta, vehicles, [], [(v, v + 1) for v in range(1, n)])


@contextmanager
def saving() -> Iterator[dict[str, Figure]]:
    """Every Figure saved within, by file name (the real savefig still writes the PNG). Drawn in this process: a
    report forks workers to draw when this process has no other thread (supervisor.analysis.drawing), and a worker's
    figures are not seen here (the first test of a fresh pytest worker met that)."""
    figures: dict[str, Figure] = {}
    original = Figure.savefig

    def record(self: Figure, fname: Any, *args: Any, **kwargs: Any) -> None:
        figures[Path(fname).name] = self
        original(self, fname, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Figure, "savefig", record)
        patch.setattr(report_module, "workers", lambda figures: 1)
        yield figures


@pytest.fixture
def saved() -> Iterator[dict[str, Figure]]:
    with saving() as figures:
        yield figures


@pytest.fixture(scope="module")
def eight(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Figure]:
    """The figures of an eight-vehicle fleet."""
    with saving() as figures:
        write_figures(fleet(8), tmp_path_factory.mktemp("eight"))
    return figures


def drawn(fig: Figure) -> Any:
    fig.canvas.draw()
    return fig.canvas.get_renderer()  # type: ignore[attr-defined]


def data_lines(fig: Figure) -> list[Any]:
    """The labelled data lines of the figure's first axes (not reference lines such as y = 0)."""
    return [line for line in fig.axes[0].get_lines() if not str(line.get_label()).startswith("_")]


# --- coordination errors -------------------------------------------------------------------------------------


def test_coordination_errors_are_pairs_for_a_small_fleet_and_one_line_per_vehicle_beyond(
    tmp_path: Path, eight: dict[str, Figure], saved: dict[str, Figure]
) -> None:
    """8 vehicles: 8 lines against the mean and the spread, all in distinct colours, not 28 pairs; 3 vehicles: the
    paper's 3 pairs, as before."""
    plotted = data_lines(eight["fig5_coordination_errors.png"])
    assert [line.get_label() for line in plotted[:8]] == [rf"$\gamma_{{{v}}}$" for v in range(1, 9)]
    assert len(plotted) == 9 and len({_rgba(line) for line in plotted}) == 9
    write_figures(fleet(3), tmp_path)
    assert len(data_lines(saved["fig5_coordination_errors.png"])) == 3


def _errors(steady: float, bump_from: float | None = None) -> tuple[Any, Any]:
    """Two pairs' errors: 40 decaying to an oscillation of `steady`, and a bump of 8 from bump_from on (a fault late
    in the run), on the figures' time grid."""
    t = np.arange(0.0, DURATION + STEP / 2, STEP)
    base = 40.0 * np.exp(-t / 8.0) + steady * np.sin(t / 3.0)
    if bump_from is not None:
        base = base + np.where(t >= bump_from, 8.0 * np.sin(np.pi * (t - bump_from) / (DURATION - bump_from)), 0.0)
    return t, np.column_stack([base, 0.5 * base])


def test_the_coordination_scale_comes_from_the_data_and_shows_the_steady_state() -> None:
    """A steady error of 1e-5 after a transient of 40: symlog, linear only within 1e-6, so the steady state shows
    (a fixed band of 1e-3 flattened it to a line on zero); the same with a fault's bump over the last quarter (the
    old rule, judging by the last quarter alone, went linear there and the steady state vanished); an error that
    never settles below a tenth of its peak: linear (issue 28)."""
    from supervisor.analysis.figures import symlog_threshold

    assert symlog_threshold(*_errors(1e-5)) == pytest.approx(1e-6)
    assert symlog_threshold(*_errors(1e-4, bump_from=150.0)) == pytest.approx(1e-5)
    t, big = _errors(10.0)
    assert symlog_threshold(t, big) is None


def test_the_coordination_figure_says_its_scale(tmp_path: Path, saved: dict[str, Figure]) -> None:
    write_figures(fleet(3), tmp_path)
    ax = saved["fig5_coordination_errors.png"].axes[0]
    assert ax.get_yscale() == "symlog"
    linthresh = ax.yaxis.get_transform().linthresh  # type: ignore[attr-defined]
    assert ax.get_ylabel().endswith(f"(symlog: linear within $\\pm${linthresh:g})")


def _rgba(line: Any) -> Any:
    from matplotlib.colors import to_rgba

    return to_rgba(line.get_color())


def test_twelve_vehicles_get_twelve_colours_in_every_per_vehicle_figure(
    tmp_path: Path, saved: dict[str, Figure]
) -> None:
    write_figures(fleet(12), tmp_path)
    for name in ("fig4_path_following_errors.png", "gamma_dot.png", "fig5_coordination_errors.png"):
        vehicles = [line for line in data_lines(saved[name]) if str(line.get_label()).startswith(("AUV", r"$\gamma_{"))]
        assert len(vehicles) == 12, name
        assert len({_rgba(line) for line in vehicles}) == 12, name


def test_coordination_against_the_mean_of_the_vehicles_alive(tmp_path: Path, saved: dict[str, Figure]) -> None:
    """Vehicle 5 down on [60, 100) s: its line breaks there (NaN, no straight line across), and the mean the
    others are drawn against is the mean of the seven alive."""
    run = fleet(8, down={5: (60.0, 100.0)})
    write_figures(run, tmp_path)
    lines = {line.get_label(): line for line in data_lines(saved["fig5_coordination_errors.png"])}
    t = np.asarray(lines[r"$\gamma_{5}$"].get_xdata(), dtype=float)
    fifth = np.asarray(lines[r"$\gamma_{5}$"].get_ydata(), dtype=float)
    gap = (t >= 60.0) & (t < 100.0)
    assert gap.any() and np.isnan(fifth[gap]).all() and np.isfinite(fifth[~gap]).all()
    first = np.asarray(lines[r"$\gamma_{1}$"].get_ydata(), dtype=float)
    alive = [s for v, s in run.vehicles.items() if v != 5]
    k = int(np.flatnonzero(np.isclose(alive[0].t, 80.0))[0])
    mean = np.mean([s.gamma[k] for s in alive])
    assert first[np.flatnonzero(np.isclose(t, 80.0))[0]] == pytest.approx(alive[0].gamma[k] - mean, abs=1e-12)


def test_a_long_legend_stays_inside_the_saved_image(eight: dict[str, Figure]) -> None:
    fig = eight["fig5_coordination_errors.png"]
    renderer = drawn(fig)
    legends = [legend for legend in (ax.get_legend() for ax in fig.axes) if legend is not None] + list(fig.legends)
    assert legends
    image = fig.bbox
    for legend in legends:
        box = legend.get_window_extent(renderer)
        assert image.x0 <= box.x0 and box.x1 <= image.x1 and image.y0 <= box.y0 and box.y1 <= image.y1


# --- trajectories --------------------------------------------------------------------------------------------


def _axes_kinds(fig: Figure) -> list[str]:
    return [ax.name for ax in fig.axes]


@pytest.mark.parametrize(("dimension", "z_span"), [(2, 0.0), (3, 0.2)])
def test_planar_and_shallow_runs_are_drawn_top_down_with_equal_axes(
    dimension: int, z_span: float, tmp_path: Path, saved: dict[str, Figure]
) -> None:
    write_figures(fleet(3, z_span=z_span, dimension=dimension), tmp_path)
    fig = saved["fig3_trajectories.png"]
    assert _axes_kinds(fig) == ["rectilinear"]
    top = fig.axes[0]
    assert top.get_aspect() == 1.0
    dashed = [line for line in top.get_lines() if line.get_linestyle() == "--"]
    solid = [line for line in top.get_lines() if line.get_linestyle() == "-"]
    assert len(dashed) == len(solid) == 3  # a desired path and a trajectory per vehicle


def test_a_deep_run_gets_an_equal_scale_3d_view_beside_the_top_down_one(
    tmp_path: Path, saved: dict[str, Figure]
) -> None:
    run = fleet(3, z_span=15.0)
    write_figures(run, tmp_path)
    fig = saved["fig3_trajectories.png"]
    assert _axes_kinds(fig) == ["3d", "rectilinear"]
    view: Any = fig.axes[0]
    spans = np.array([np.ptp(view.get_xlim()), np.ptp(view.get_ylim()), np.ptp(view.get_zlim())])
    box = np.asarray(view.get_box_aspect(), dtype=float)
    np.testing.assert_allclose(box / box[0], spans / spans[0], rtol=1e-6)  # one metre as long on every axis
    assert fig.axes[1].get_aspect() == 1.0


# --- sweep plots ---------------------------------------------------------------------------------------------


def sweep_rows(errors: dict[float, float], resync: float | None = 30.0) -> list[dict[str, Any]]:
    return [
        {"comms.loss": loss, "coordination.k": k, "seed": seed, "steady_coordination_error": error * (1 + 1e-6 * seed),
         "resync_time": resync, "sent": 100, "delivered": int(100 * (1 - loss))}
        for loss, error in errors.items() for k in (0.2, 0.4) for seed in range(3)
    ]  # fmt: skip


LOSS = Param("comms.loss", (0.0, 0.05, 0.1))
GAINS = Param("coordination.k", (0.2, 0.4))


def visible_labels(ax: Any) -> list[str]:
    low, high = sorted(ax.get_ylim())
    ticks = [*ax.yaxis.get_major_ticks(), *ax.yaxis.get_minor_ticks()]
    labels: list[Text] = [t.label1 for t in ticks if low <= t.get_loc() <= high and t.label1.get_visible()]
    return [label.get_text() for label in labels if label.get_text()]


def test_a_log_axis_over_less_than_a_decade_has_distinct_tick_labels(tmp_path: Path, saved: dict[str, Figure]) -> None:
    """Errors within 1e-5 of 5.2332 (a fault holding the fleet apart, whatever the loss): no repeated labels."""
    plot_sweep(sweep_rows({0.0: 5.23320, 0.05: 5.23322, 0.1: 5.23321}), [LOSS, GAINS], tmp_path)
    fig = saved["sweep_comms_loss.png"]
    drawn(fig)
    error_ax = fig.axes[0]
    assert error_ax.get_yscale() == "log"
    labels = visible_labels(error_ax)
    assert len(labels) >= 2
    assert len(labels) == len(set(labels)), labels


def test_no_plot_for_a_parameter_with_a_single_value(tmp_path: Path, saved: dict[str, Figure]) -> None:
    rows = [r for r in sweep_rows({0.1: 1.0, 0.2: 0.5}) if r["comms.loss"] == 0.1]
    paths = plot_sweep(rows, [Param("comms.loss", (0.1,)), GAINS], tmp_path)
    assert [p.name for p in paths] == ["sweep_coordination_k.png"]
    assert "comms.loss=0.1" in saved["sweep_coordination_k.png"].get_suptitle()
    assert plot_sweep(rows, [Param("comms.loss", (0.1,))], tmp_path / "none") == []


def test_a_sweep_where_no_run_resynchronises_plots_without_a_warning(tmp_path: Path, saved: dict[str, Figure]) -> None:
    """No run has a resync time (never back below tolerance): that panel is empty, says so, and warns nothing
    (pytest turns warnings into errors; an empty legend() used to warn)."""
    plot_sweep(sweep_rows({0.0: 1.0, 0.1: 2.0}, resync=None), [Param("comms.loss", (0.0, 0.1))], tmp_path)
    resync_ax = saved["sweep_comms_loss.png"].axes[1]
    assert not resync_ax.get_lines() and resync_ax.get_legend() is None
    assert [t.get_text() for t in resync_ax.texts] == ["no run has a value"]


def test_a_fault_free_sweep_draws_when_the_fleet_came_below_tolerance(tmp_path: Path, saved: dict[str, Figure]) -> None:
    """No fault, so no run has a resync time; the middle panel draws sync_time (below tolerance to stay, from the
    start), which results.csv has, instead of staying empty (issue 28)."""
    rows = [{**r, "sync_time": 40.0 + 100.0 * r["comms.loss"]} for r in sweep_rows({0.0: 1.0, 0.1: 2.0}, None)]
    plot_sweep(rows, [Param("comms.loss", (0.0, 0.1))], tmp_path)
    panel = saved["sweep_comms_loss.png"].axes[1]
    assert panel.get_title() == "Coordination below tolerance (to stay) at" and not panel.texts
    median = next(line for line in panel.get_lines())
    assert np.asarray(median.get_ydata()).tolist() == [40.0, 50.0]


# --- real runs of the example scenarios ------------------------------------------------------------------------

DATA = Path(__file__).resolve().parent / "data"


def real_figures(name: str, duration: float, out: Path, overrides: tuple[str, ...] = ()) -> dict[str, Figure]:
    """The figures of tests/data/<name>, run in process for `duration` s with --set overrides."""
    text = shortened((DATA / name).read_text(), duration)
    scenario = parse_scenario(text, name, overrides, ())
    log = out / "run.mcap"
    run_inprocess(scenario, name, text, log, 0, Progress(duration, io.StringIO(), enabled=False))
    with saving() as figures:
        write_report(log, out)
    return figures


def test_the_planar_paper_variant_is_drawn_top_down(tmp_path: Path) -> None:
    fig = real_figures("fig_planar_paper.toml", 30.0, tmp_path)["fig3_trajectories.png"]
    assert _axes_kinds(fig) == ["rectilinear"] and fig.axes[0].get_aspect() == 1.0


def test_eight_circles_with_a_kill_plot_eight_vehicles_against_the_mean(tmp_path: Path) -> None:
    """Vehicle 5 killed on [20, 30) s: its line has a gap there, and nine lines in all."""
    faults = ("faults.0.start=5", "faults.0.end=10", "faults.1.start=20", "faults.1.end=30")
    fig = real_figures("fig_circles8.toml", 40.0, tmp_path, faults)["fig5_coordination_errors.png"]
    lines = {line.get_label(): line for line in data_lines(fig)}
    assert len(lines) == 9
    t = np.asarray(lines[r"$\gamma_{5}$"].get_xdata(), dtype=float)
    down = np.isnan(np.asarray(lines[r"$\gamma_{5}$"].get_ydata(), dtype=float))
    assert down.any() and t[down].min() >= 19.9 and t[down].max() < 30.0

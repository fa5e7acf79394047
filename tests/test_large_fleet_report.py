"""The report of a large fleet (supervisor.analysis.condense): past MAX_ROWS vehicles or links, the per-vehicle and
per-link figures draw the SHOWN a reader looks for first (the vehicles furthest off their paths, the links that
delivered least, the vehicles whose estimates got oldest) and say so in their titles; past LEGEND_VEHICLES_MAX
vehicles a colour bar names the vehicles' hues where a legend of 1000 entries overflowed the image. A report of
1000 AUVs took over 10 minutes (killed) and now takes ~15 s.

A ring of 70 AUVs (140 directed links), 3 s, in-process; its first vehicle starts on its path's far side.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from benchmarks.bench_scaling import ring_scenario
from supervisor.analysis.condense import MAX_ROWS, SHOWN
from supervisor.analysis.figures import fig_coordination_errors, fig_trajectories
from supervisor.analysis.figures_current import fig_current_estimates
from supervisor.analysis.legends import LEGEND_VEHICLES_MAX
from supervisor.analysis.report import figure_builders, velocity_figure_vehicles
from supervisor.analysis.report_comms import fig_estimate_age, fig_packets, shown_links
from supervisor.analysis.rundata import RunData, load_run
from tests.procs import cpf

FLEET = 70


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> RunData:
    where = tmp_path_factory.mktemp("ring")
    text = ring_scenario(FLEET, 3.0).replace("position = [-2.0, 12.0, -10.0]", "position = [-2.0, 30.0, -10.0]")
    (where / "ring.toml").write_text(text + "\n[comms]\nloss = 0.3\n")
    done = cpf("run", "ring.toml", "--engine", "inprocess", "--quiet", "--out", "r.mcap", cwd=where)
    assert done.returncode == 0, done.stderr
    return load_run(where / "r.mcap")


def test_the_fleet_is_larger_than_every_table_and_legend(run: RunData) -> None:
    assert len(run.vehicles) == FLEET > LEGEND_VEHICLES_MAX > MAX_ROWS and len(run.links) == 2 * FLEET


def test_velocity_figures_go_to_the_vehicles_furthest_off_their_paths(run: RunData) -> None:
    worst = {v: float(np.nanmax(s.error_norm)) for v, s in run.vehicles.items()}
    chosen = velocity_figure_vehicles(run)
    assert len(chosen) == SHOWN and 1 in chosen  # the one started 18 m off
    assert min(worst[v] for v in chosen) >= max(worst[v] for v in run.vehicles if v not in chosen)
    names = [name for name, _ in figure_builders(run) if name.startswith("fig6_")]
    assert names == [f"fig6_velocities_auv{v}" for v in chosen]


def test_link_figures_go_to_the_links_that_delivered_least_and_say_so(run: RunData) -> None:
    share = {link.name: link.times("delivered").size / link.times("sent").size for link in run.links.values()}
    links, which = shown_links(run)
    assert which == f" (the {SHOWN} of {2 * FLEET} links that delivered least)" and len(links) == SHOWN
    assert max(share[link.name] for link in links) <= min(s for name, s in share.items() if name not in
                                                          {link.name for link in links})  # fmt: skip
    fig = fig_packets(run)
    assert which in fig.get_suptitle()
    assert sum(ax.get_visible() for ax in fig.axes) == SHOWN


def _colour_bars(fig: Figure) -> list[str]:
    return [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel().endswith("one hue each")]


def test_a_colour_bar_names_the_vehicles_where_a_legend_would_not_fit(run: RunData) -> None:
    for fig in (fig_coordination_errors(run), fig_trajectories(run)):
        assert _colour_bars(fig) == [f"{FLEET} vehicles, one hue each"]
    legend = fig_coordination_errors(run).axes[0].get_legend()
    assert legend is not None and [t.get_text() for t in legend.get_texts()] == [
        r"spread $\max_i \gamma_i - \min_i \gamma_i$"
    ]  # the other entries stay


def test_a_fleet_within_the_legend_keeps_its_legend(tmp_path: Path) -> None:
    (tmp_path / "ring.toml").write_text(ring_scenario(8, 1.0))
    assert cpf("run", "ring.toml", "--quiet", "--out", "r.mcap", cwd=tmp_path).returncode == 0
    small = load_run(tmp_path / "r.mcap")
    fig = fig_coordination_errors(small)
    assert _colour_bars(fig) == [] and len(fig.axes[0].get_legend().get_texts()) == 8 + 1  # type: ignore[union-attr]
    assert len(velocity_figure_vehicles(small)) == 8 and len(shown_links(small)[0]) == 16


@pytest.fixture(scope="module")
def dense(tmp_path_factory: pytest.TempPathFactory) -> RunData:
    """70 AUVs, every pair linked (69 neighbours each), estimating a current, 1 s."""
    where = tmp_path_factory.mktemp("dense")
    edges = ", ".join(f"[{i}, {j}]" for i in range(1, FLEET + 1) for j in range(i + 1, FLEET + 1))
    text = re.sub(r"edges = \[.*\]", f"edges = [{edges}]", ring_scenario(FLEET, 1.0))
    (where / "dense.toml").write_text(text + '\n[environment]\ncurrent = [0.2, 0.1, 0.0]\nestimate_current = "on"\n')
    done = cpf("run", "dense.toml", "--engine", "inprocess", "--quiet", "--out", "r.mcap", cwd=where)
    assert done.returncode == 0, done.stderr
    return load_run(where / "r.mcap")


def test_estimate_ages_of_many_neighbours_share_one_colour_bar(dense: RunData) -> None:
    fig = fig_estimate_age(dense)
    assert _colour_bars(fig) == [f"{FLEET} vehicles, one hue each"]  # (10 panels had a legend of 69 entries each)
    assert all(ax.get_legend() is None for ax in fig.axes)


def test_current_estimates_of_a_large_fleet_have_one_colour_bar(dense: RunData) -> None:
    assert _colour_bars(fig_current_estimates(dense)) == [f"{FLEET} vehicles, one hue each"]  # (one per axis)

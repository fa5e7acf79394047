"""The run summary of a large fleet (supervisor.analysis.condense): a table with more than MAX_ROWS rows prints the
SHOWN a reader looks for first (links that delivered least, vehicles longest at an input limit), then all links
added up, and says so; the mean gamma_dot of many vehicles is their range. Up to MAX_ROWS, every row as before."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from supervisor.analysis.comms_summary import CommsSummary, LinkRow, format_comms
from supervisor.analysis.condense import MAX_ROWS, SHOWN
from supervisor.analysis.input_limits import InputTime, format_input_limits
from supervisor.analysis.summary import PhaseStats, Summary, format_summary


def ring_links(n: int) -> tuple[LinkRow, ...]:
    """Links i -> i+1 of a ring; link k delivers all but k % 7 of its 20 packets, 0.1 s late on average."""
    return tuple(
        LinkRow(i, i % n + 1, 20, 20 - i % 7, {"noise": i % 7} if i % 7 else {}, 0.1 * i, 0.2 * i, 1.0, 2.0 + i)
        for i in range(1, n + 1)
    )


def test_a_long_link_table_shows_the_links_that_delivered_least_and_all_of_them_added_up():
    links = ring_links(300)
    lines = format_comms(CommsSummary(links, None, None, 0)).splitlines()
    shown = [line.split()[0] for line in lines[1 : 1 + SHOWN]]
    assert shown == [f"{i}->{i + 1}" for i in (6, 13, 20, 27, 34, 41, 48, 55, 62, 69)]  # 14 of 20; in order on ties
    total = lines[1 + SHOWN].split()
    delivered = sum(r.delivered for r in links)
    assert total[:4] == ["all", "300", str(20 * 300), str(delivered)]
    assert f"{sum(i % 7 for i in range(1, 301))} noise" in lines[1 + SHOWN]
    mean_delay = sum(0.1 * r.sender * r.delivered for r in links) / delivered  # weighted by what each delivered
    assert f"{mean_delay:.2f} / {0.2 * 300:.2f}" in lines[1 + SHOWN] and f"1.00 / {2.0 + 300:.2f}" in lines[1 + SHOWN]
    assert lines[2 + SHOWN].startswith(f"(above: the {SHOWN} of 300 links that delivered least")
    assert len(lines) == 3 + SHOWN


def test_a_table_up_to_its_limit_prints_every_row_in_order():
    lines = format_comms(CommsSummary(ring_links(MAX_ROWS), None, None, 0)).splitlines()
    assert [line.split()[0] for line in lines[1:]] == [f"{i}->{i % MAX_ROWS + 1}" for i in range(1, MAX_ROWS + 1)]


def test_many_vehicles_at_a_limit_show_those_there_longest():
    times = [InputTime(v, (0.0, float(v % 10), 0.0), 100.0) for v in range(1, 61)]  # six vehicles to each share
    lines = str(format_input_limits(times)).splitlines()
    assert [int(line.split()[1][:-1]) for line in lines[:SHOWN]] == [9, 19, 29, 39, 49, 59, 8, 18, 28, 38]  # ties: in
    # the fleet's order
    assert lines[SHOWN].startswith(f"(above: the {SHOWN} of 54 vehicles at a limit")  # (10, 20, ...: never at one)
    assert len(lines) == SHOWN + 1
    few = str(format_input_limits(times[:MAX_ROWS])).splitlines()
    assert len(few) == MAX_ROWS - 2 and few[0] == "vehicle 1: inputs at their limits for pitch 1 % of its time"


def test_a_long_table_with_large_counts_keeps_its_columns_apart():
    """(The total of 1560 links of 700 packets ran into its own numbers: 'all 156010920001076400'.)"""
    links = tuple(LinkRow(i, i + 1, 700, 690, {"noise": 10}, 0.1, 0.2, 1.0, 2.0) for i in range(1, 1561))
    total = format_comms(CommsSummary(links, None, None, 0)).splitlines()[1 + SHOWN].split()
    assert total[:5] == ["all", "1560", str(700 * 1560), str(690 * 1560), str(10 * 1560)]


def test_the_mean_gamma_dot_of_many_vehicles_is_their_range():
    rates = tuple([math.nan] + [0.5 + 0.001 * i for i in range(1, 40)])
    phase = PhaseStats("whole run", 0.0, 10.0, 1.0, 0.5, math.nan, rates)
    text = format_summary(Summary((phase,), 1.2, math.nan, None, None, 0.01)).splitlines()[1]
    assert text.endswith("0.501 to 0.539 over 40 vehicles")
    few = PhaseStats("whole run", 0.0, 10.0, 1.0, 0.5, math.nan, rates[:3])
    assert format_summary(Summary((few,), 1.2, math.nan, None, None, 0.01)).splitlines()[1].endswith("- 0.501 0.502")


def test_the_headline_of_a_run_slower_than_real_time_says_how_much_slower():
    """(It said "0x real time" for 1000 AUVs at 0.33x.)"""
    from types import SimpleNamespace

    from supervisor.cli.run_report import _headline
    from supervisor.config.scenario import parse_scenario
    from tests.conftest import CONFIGS

    sc = parse_scenario((CONFIGS / "paper.toml").read_text(), "paper.toml")
    result: Any = SimpleNamespace(stepping_time=1200.0, wall_time=1210.0, scene_messages=0, messages=5)
    args: Any = SimpleNamespace(engine="inprocess")
    assert "(stepping 1200.00 s, 0.33x real time)" in _headline(args, sc, result, Path("r.mcap"))
    result.stepping_time = 4.0
    assert "(stepping 4.00 s, 100x real time)" in _headline(args, sc, result, Path("r.mcap"))


def test_cpf_info_of_a_large_fleet_names_its_vehicles_edges_and_topics_in_a_few_lines(tmp_path):
    """(1000 AUVs: a vehicles line of 1000 ids, a graph line of 1000 edges and 5000 topic lines.)"""
    from benchmarks.bench_scaling import ring_scenario
    from tests.procs import cpf

    (tmp_path / "ring.toml").write_text(ring_scenario(30, 1.0))
    assert cpf("run", "ring.toml", "--engine", "inprocess", "--quiet", "--out", "r.mcap", cwd=tmp_path).returncode == 0
    info = cpf("info", "r.mcap", cwd=tmp_path)
    lines = {line.split()[0]: line for line in info.stdout.splitlines() if line and not line.startswith(" ")}
    assert lines["vehicles"].split(None, 1)[1] == "1-30 (each remus100)"
    assert lines["graph"].split(None, 1)[1] == "30 edges: 1-2, 2-3, 3-4, 4-5, 5-6, ..., 29-30, 30-1"
    states = [line for line in info.stdout.splitlines() if "cpf/vehicle/<id>/state" in line]
    assert len(states) == 1 and states[0].split()[1:] == ["300", "(30", "topics,", "10-10", "each)"]
    assert len(info.stdout.splitlines()) < 40


def test_topics_alike_but_for_an_id_group_only_past_the_limit():
    from supervisor.tools.info import topic_lines

    few = {f"cpf/vehicle/{v}/state": 5 for v in range(1, MAX_ROWS + 1)}
    assert len(topic_lines(few)) == MAX_ROWS
    many = {**{f"foxglove/trail/{v}": v for v in range(1, 31)}, "foxglove/scene": 3}
    assert topic_lines(many) == [
        "  foxglove/scene                     3",
        f"  {'foxglove/trail/<id>':<28}{sum(range(1, 31)):>8}  (30 topics, 1-30 each)",
    ]


def test_the_summary_and_the_report_pick_the_same_links_the_same_way():
    """One selection (condense.first_looked_at) and one share (condense.delivered_share): a link that sent nothing
    lost nothing (the report counted it as delivering none, the summary as delivering all)."""
    from supervisor.analysis.condense import delivered_share, first_looked_at

    assert delivered_share(0, 0) == 1.0 and delivered_share(4, 1) == 0.25
    links = [(i, 0 if i % 3 == 0 else 10, 10 - i % 5) for i in range(1, 40)]  # (name, sent, delivered)
    shown = first_looked_at(links, lambda x: delivered_share(x[1], x[2]))
    assert len(shown) == SHOWN and all(sent for _, sent, _ in shown)
    assert first_looked_at(links[:MAX_ROWS], lambda x: 0.0) == links[:MAX_ROWS]

"""`import cpf`: the Python API gives the numbers `cpf run` prints and writes, through the command line's own code.

One shortened paper run (200 s: the phase before the speed cap and the cap itself, 20 % loss so links drop packets)
is run by `cpf run --metrics` as a user would, then loaded with cpf.load: the tables must give metrics.json's and
the printed summary's numbers, computed here from the tables' own columns.
"""

from __future__ import annotations

import inspect
import io
import json
import logging
import math
import re
from pathlib import Path

import msgspec
import numpy as np
import pandas as pd
import pytest

import cpf
from comms.records.state import StateReport
from tests.conftest import CONFIGS, shortened
from tests.procs import cpf as cpf_command
from tests.test_state_report import REPORT

LOSSY = ("--set", "comms.loss=0.2")


@pytest.fixture(scope="module")
def scenario(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("api") / "short.toml"
    path.write_text(shortened((CONFIGS / "paper.toml").read_text(), 200.0))
    return path


@pytest.fixture(scope="module")
def cli_run(scenario) -> tuple[cpf.Run, dict, str]:
    """(the run cpf.load reads, --metrics JSON, printed summary) of one `cpf run`."""
    where = scenario.parent
    done = cpf_command("run", str(scenario), "--engine", "inprocess", *LOSSY, "--metrics", "m.json",
                       "--out", "run.mcap", "--quiet", cwd=where)  # fmt: skip
    assert done.returncode == 0, done.stderr
    return cpf.load(where / "run.mcap"), json.loads((where / "m.json").read_text()), done.stdout


def test_phase_table_is_the_summary_of_cpf_run(cli_run):
    run, metrics, _ = cli_run
    phases = metrics["coordination"]["phases"]
    assert list(run.metrics["phase"]) == ["before faults", "during speed_cap"] == [p["name"] for p in phases]
    for name in ("max_coordination_error", "final_coordination_error", "max_path_error"):
        np.testing.assert_allclose(run.metrics[name], [p[name] for p in phases], rtol=1e-12, err_msg=name)
    for vid in (1, 2, 3):
        expected = [p["mean_gamma_dot"][vid - 1] for p in phases]
        np.testing.assert_allclose(run.metrics[f"mean_gamma_dot_{vid}"], expected, rtol=1e-12)
    assert run.summary["path_following"]["max_error_after_transient"] == pytest.approx(
        metrics["coordination"]["max_path_error_after_transient"], rel=1e-12
    )


def test_states_give_the_coordination_and_path_errors_of_cpf_run(cli_run):
    """The same numbers, from the states table's columns alone."""
    run, metrics, printed = cli_run
    states = run.states
    gamma = states.pivot(index="t", columns="vehicle", values="gamma")
    coordination = gamma.max(axis=1) - gamma.min(axis=1)
    for p in metrics["coordination"]["phases"]:
        within = (coordination.index >= p["start"]) & (coordination.index < p["end"])
        assert coordination[within].max() == pytest.approx(p["max_coordination_error"], rel=1e-12)
        rows = states[(states.t >= p["start"]) & (states.t < p["end"])]
        rates = rows.groupby("vehicle").gamma_dot.mean()
        np.testing.assert_allclose(rates.to_numpy(), p["mean_gamma_dot"], rtol=1e-12)
    transient = metrics["coordination"]["transient"]
    worst = states[states.t >= transient].path_error.max()
    assert worst == pytest.approx(metrics["coordination"]["max_path_error_after_transient"], rel=1e-12)
    assert f"path-following error after the transient (from t = {transient:g} s): max {worst:.3f} m" in printed
    assert len(states) == 3 * 2000 and states.position_x.notna().all()


def test_link_events_count_what_cpf_run_counted(cli_run):
    run, metrics, printed = cli_run
    counts = run.link_events.groupby(["sender", "receiver", "kind"]).size()
    for link in metrics["comms"]["links"]:
        key = (link["sender"], link["receiver"])
        assert counts[(*key, "sent")] == link["sent"]
        assert counts[(*key, "delivered")] == link["delivered"]
        assert counts.get((*key, "dropped"), 0) == sum(link["dropped"].values())
        assert f"{key[0]}->{key[1]:<5}{link['sent']:>7}{link['delivered']:>7}" in printed
    kinds = run.link_events.kind.value_counts()
    assert {k: int(kinds[k]) for k in ("sent", "delivered", "dropped")} == metrics["links"]
    assert kinds["dropped"] > 0  # 20 % loss: the test sees drops
    delivered = run.link_events[run.link_events.kind == "delivered"]
    in_time = delivered[delivered.t <= run.states.t.max()]  # one arriving after the last step is never taken in
    packets = ["sender", "receiver", "seq"]
    taken = run.receptions[packets]
    assert sorted(map(tuple, taken.to_numpy())) == sorted(map(tuple, in_time[packets].to_numpy()))
    assert 0 < len(delivered) - len(in_time) <= 3
    sent = run.link_events[run.link_events.kind == "sent"].groupby("sender").size()
    out_links = {1: 2, 2: 1, 3: 1}  # graph 1-2, 1-3: each packet is sent on every link out of its sender
    assert run.transmissions.groupby("sender").size().mul(pd.Series(out_links)).to_dict() == sent.to_dict()


def test_faults_table_holds_the_speed_cap(cli_run):
    run, _, _ = cli_run
    faults = run.faults
    assert list(faults.kind) == ["speed_cap"] and list(faults.phase) == ["start"]
    assert faults.t[0] == 150.0 and faults.vehicle[0] == 1 and json.loads(faults.detail[0])["end"] == 250.0


def test_figures_are_the_reports(cli_run):
    run, _, _ = cli_run
    figures = run.figures()
    assert list(figures)[:3] == ["fig3_trajectories", "fig4_path_following_errors", "fig5_coordination_errors"]
    assert all(figure.axes for figure in figures.values())


@pytest.mark.integration
def test_both_engines_give_identical_tables(scenario):
    """Every table bit for bit, rows in the same order (transmissions and receptions came in each engine's log order:
    the same rows, but a comparison failed, found by new users)."""
    short = shortened(scenario.read_text(), 15.0)
    runs = [cpf.run(short, engine=engine, set={"comms.loss": 0.2}, progress=False) for engine in ("inprocess", "zenoh")]
    for table in ("states", "transmissions", "receptions", "link_events", "faults"):
        pd.testing.assert_frame_equal(getattr(runs[0], table), getattr(runs[1], table), check_exact=True)
    assert len(runs[0].states) == 3 * 150 and len(runs[0].receptions) > 0


def test_run_takes_text_dicts_and_lists_of_changes(scenario, tmp_path):
    import tomllib

    data = tomllib.loads(shortened(scenario.read_text(), 2.0))
    by_dict = cpf.run(data, set={"comms.loss": 0.5}, faults=[{"kind": "blackout", "start": 1.0}], progress=False)
    by_text = cpf.run(str(scenario), set=["comms.loss=0.5", "scenario.duration=2"], faults=["kind=blackout,start=1"],
                      out=tmp_path / "r.mcap", progress=False)  # fmt: skip
    assert by_text.log == tmp_path / "r.mcap" and by_text.log.is_file()
    pd.testing.assert_frame_equal(by_dict.states, by_text.states)
    assert list(by_dict.faults.kind) == ["blackout"]
    log = by_dict.log
    del by_dict
    assert not log.exists()  # the temporary log goes with its Run


def test_progress_is_a_tqdm_bar_on_stderr_unless_turned_off(scenario, capsys):
    """tqdm.auto: this text bar in a terminal (and here)."""
    short = shortened(scenario.read_text(), 2.0).replace("start = 150.0", "start = 1.0")
    cpf.run(short, progress=True)
    shown = capsys.readouterr()
    final = shown.err.replace("\r", "\n").strip().splitlines()[-1]
    assert shown.out == "" and final.startswith("simulated: 2.0/2 s |") and "x real time" in final
    cpf.run(short, progress=False)
    assert capsys.readouterr() == ("", "")


@pytest.mark.parametrize(
    ("options", "named"),
    [(["--engine", "zenoh"], "--engine"), (["--seed=2"], "--seed"), (["--out", "o2.mcap"], "--out"),
     (["--help"], "--help"), (["--quiet"], "--quiet"), (["--eng", "zenoh"], "--engine"), (["--ou=x.mcap"], "--out")],
)  # fmt: skip
def test_options_that_repeat_an_argument_of_run_are_refused(scenario, options, named):
    """Which one won depended on the option (--engine the option's, --seed the argument's, --out the option's with a
    Run of the other log), and --help printed and raised SystemExit (found by a new user)."""
    with pytest.raises(cpf.ScenarioError, match=f"^options: {named} is cpf.run's own"):
        cpf.run(scenario, progress=False, options=options)


def test_every_line_the_run_logs_is_under_the_cpf_logger(scenario, caplog):
    """A kill and restart were logged under supervisor.plan.faults, outside logger cpf: silencing cpf left them on
    stderr (found by a new user). Every logger of ours is under cpf now."""
    short = shortened(scenario.read_text(), 4.0)
    kill = {"kind": "vehicle_kill", "vehicle": 2, "start": 1.0, "end": 2.0}
    cpf.run(short, faults=[kill], progress=False)
    assert any("vehicle 2 killed at t = 1.0 s" in r.message and r.name.startswith("cpf.") for r in caplog.records)
    caplog.clear()
    logging.getLogger("cpf").setLevel(logging.ERROR)
    try:
        cpf.run(short, faults=[kill], progress=False)
    finally:
        logging.getLogger("cpf").setLevel(logging.NOTSET)
    assert caplog.records == []


@pytest.mark.parametrize(
    ("api", "cli"),
    [
        ({"set": {"scenario.step": -1}}, ["--set", "scenario.step=-1"]),
        ({"set": ["graph.edges=[[1,9]]"]}, ["--set", "graph.edges=[[1,9]]"]),
        ({"faults": ["kind=nope"]}, ["--fault", "kind=nope"]),
        ({"seed": -1}, ["--seed", "-1"]),
        ({"engine": "warp"}, ["--engine", "warp"]),
    ],
    ids=["set", "set-list", "fault", "seed", "engine"],
)
def test_bad_input_raises_what_the_command_line_says(scenario, api, cli, monkeypatch):
    done = cpf_command("run", scenario.name, *cli, "--out", "bad.mcap", cwd=scenario.parent)
    assert done.returncode == 2
    said = [line for line in done.stderr.splitlines() if "error: " in line]
    monkeypatch.chdir(scenario.parent)  # the file named as the command line names it
    with pytest.raises(cpf.ScenarioError) as caught:
        cpf.run(scenario.name, **api, out="bad.mcap", progress=False)
    assert [line.split("error: ", 1)[1] for line in said] == caught.value.errors
    assert not (scenario.parent / "bad.mcap").exists()


def test_load_refuses_what_is_not_a_log(tmp_path):
    (tmp_path / "x.mcap").write_text("not a log")
    with pytest.raises(cpf.LogError, match=r"x.mcap: not an MCAP file"):
        cpf.load(tmp_path / "x.mcap")


def test_sweep_gives_the_rows_of_cpf_sweep(scenario, capsys):
    short = scenario.parent / "sweep.toml"
    short.write_text(shortened(scenario.read_text(), 10.0))
    grid = ["--param", "comms.loss=0.1,0.3", "--seeds", "2", "--jobs", "2"]
    done = cpf_command("sweep", short.name, *grid, "--out", "cli_sweep", cwd=scenario.parent)
    assert done.returncode == 0, done.stderr
    table = cpf.sweep(short, params={"comms.loss": [0.1, 0.3]}, seeds=2, jobs=2)
    assert "4/4" in capsys.readouterr().err  # tqdm.auto's bar
    written = pd.read_csv(scenario.parent / "cli_sweep" / "results.csv")
    assert list(table.columns) == list(written.columns)
    assert list(zip(table["comms.loss"], table.seed, strict=True)) == [(0.1, 0), (0.1, 1), (0.3, 0), (0.3, 1)]
    as_written = pd.read_csv(io.StringIO(table.to_csv(index=False)))  # the same text: exact, whatever the types
    pd.testing.assert_frame_equal(as_written.drop(columns="wall_s"), written.drop(columns="wall_s"), check_exact=True)
    assert table.delivered.nunique() == 4  # every run its own draws


def test_a_sweep_keeping_logs_wants_a_directory_and_leaves_them_there(scenario):
    short = scenario.parent / "sweep.toml"
    short.write_text(shortened(scenario.read_text(), 5.0))
    with pytest.raises(cpf.ScenarioError, match=r"logs=True keeps each run's log in out/runs/: give out a directory"):
        cpf.sweep(short, params={"comms.loss": [0.1]}, seeds=1, logs=True)
    table = cpf.sweep(short, params={"comms.loss": [0.1]}, seeds=2, out=scenario.parent / "kept", logs=True)
    logs = sorted((scenario.parent / "kept" / "runs").glob("*.mcap"))
    assert len(logs) == 2 == len(table)
    assert sorted(scenario.parent / "kept" / log for log in table.log) == logs  # each row names its log
    assert sorted(cpf.load(log).states.t.max() for log in logs) == pytest.approx([4.9, 4.9])


def test_the_readmes_example_runs(tmp_path, monkeypatch, capsys):
    """The README's Python block, as written, on a 30 s paper scenario (the full one takes a few seconds per run)."""
    readme = (CONFIGS.parent / "README.md").read_text(encoding="utf-8")
    code = readme.split("\n## Python API\n", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    (tmp_path / "paper.toml").write_text(shortened((CONFIGS / "paper.toml").read_text(), 30.0))
    assert code.count('"configs/paper.toml"') == 2
    monkeypatch.chdir(tmp_path)
    exec(compile(code.replace('"configs/paper.toml"', '"paper.toml"'), "README.md", "exec"), {})
    shown = capsys.readouterr().out
    assert "max_coordination_error" in shown and "whole run" in shown and "steady_coordination_error" in shown
    assert "loss" in shown  # the drops by cause
    assert (tmp_path / "coordination.png").read_bytes().startswith(b"\x89PNG")


def test_every_field_of_the_state_record_has_a_column():
    """A field added to the state record must show in the states table (named by it, or as NAMED says)."""
    from msgspec.structs import fields

    from comms.records.state import NeighbourAge, StateReport
    from supervisor.analysis.tables import states_table

    named = {"nav_estimate": "nav_x", "rx_lateness": "rx_lateness_max", "step_lateness": "step_lateness"}
    report = StateReport(
        t=0.1, k=1, vehicle=1, gamma=0.5, gamma_dot=1.0, position=(1.0, 2.0, 3.0), rotation=(1, 0, 0, 0, 1, 0, 0, 0, 1),
        velocity=(1.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.1), error=(0.3, 0.4, 0.0), tau=(1.0, 2.0),
        correction=0.0, lyapunov=0.1, tx_seq=1, estimate_age=(NeighbourAge(2, 0.5),), rx_lateness=(0.01, 0.02),
        step_lateness=0.003, nav_estimate=tuple(float(i) for i in range(27)), nav_fix=1,
        current_estimate=(0.2, -0.1, 0.0), frozen=(0.4, 1.0),
    )  # fmt: skip
    row = states_table([report]).iloc[0]
    for f in fields(StateReport):
        prefix = named.get(f.name, f.name)
        assert any(column.startswith(prefix) for column in row.index), f"no column for StateReport.{f.name}"
    assert (row.path_error, row.estimate_age_2, row.rx_lateness_max, row.nav_bias_w, row.nav_cov_55) == (
        0.5, 0.5, 0.02, 5.0, 26.0
    )  # fmt: skip
    assert (row.current_estimate_x, row.current_estimate_y) == (0.2, -0.1)


class _WithDepthRate(StateReport, frozen=True, omit_defaults=True):
    """The state record with one field more, as a contributor would add it to comms.records.state.StateReport."""

    depth_rate: float | None = None


def test_a_field_added_to_the_state_record_gets_its_column_with_no_other_edit():
    """Issue 25: adding a field to the state message is one edit (its struct) and a test; the table follows."""
    from supervisor.analysis.tables import states_table

    base = msgspec.structs.asdict(REPORT)
    rows = states_table([_WithDepthRate(**base, depth_rate=0.05), _WithDepthRate(**base)])
    assert list(rows["depth_rate"].iloc[:1]) == [0.05] and math.isnan(rows["depth_rate"].iloc[1])


def test_the_api_docs_show_each_functions_signature_as_it_is():
    """docs/api.md's signature lines (cpf.run, cpf.load, cpf.sweep) name every parameter with its default, as the
    functions have them: the page drifted once (cpf.sweep's jobs=2 and no logs, after both changed)."""
    page = (CONFIGS.parent / "docs" / "api.md").read_text(encoding="utf-8")
    shown = dict(re.findall(r"(?m)^cpf\.(\w+)\((.*)\) -> ", page))
    assert set(shown) == {"run", "load", "sweep"}

    def written(p: inspect.Parameter) -> str:
        if p.default is inspect.Parameter.empty:
            return p.name
        return f"{p.name}={json.dumps(p.default) if isinstance(p.default, str | bool) else repr(p.default)}"

    for name, params in shown.items():
        actual = ", ".join(written(p) for p in inspect.signature(getattr(cpf, name)).parameters.values())
        assert params == actual.replace("=false", "=False").replace("=true", "=True"), name


def test_sweeping_the_scenarios_seed_is_refused_for_seeds(scenario):
    """A run's seed is the sweep's (0 .. seeds-1): --param scenario.seed=1,2 gave rows all of seed 0 and the same
    numbers, and a figure of them (found by a new user). Refused, by the command line and cpf.sweep alike."""
    done = cpf_command("sweep", scenario.name, "--param", "scenario.seed=1,2", "--out", "seeded", cwd=scenario.parent)
    said = [line.split("error: ", 1)[1] for line in done.stderr.splitlines() if "error: " in line]
    assert done.returncode == 2 and not (scenario.parent / "seeded").exists()
    assert said == [
        "--param scenario.seed: a sweep gives each run its seed (0 .. N-1 of --seeds N; seeds=N in cpf.sweep) over "
        "the scenario's: sweep seeds with --seeds, got 'scenario.seed=1,2'"
    ]
    with pytest.raises(cpf.ScenarioError) as caught:
        cpf.sweep(scenario, params={"scenario.seed": [1, 2], "comms.loss": [0.3]}, seeds=1, progress=False)
    assert caught.value.errors == said


def test_run_writes_the_metrics_file_of_cpf_run(scenario, cli_run, tmp_path):
    """options=["--metrics", FILE] was accepted and nothing written (only the command line's printing wrote it; found
    by a new user): the file is cpf run --metrics's, the same JSON for the same run."""
    _, metrics, _ = cli_run
    cpf.run(scenario, set={"comms.loss": 0.2}, progress=False, options=["--metrics", str(tmp_path / "m.json")])
    assert json.loads((tmp_path / "m.json").read_text()) == metrics


def test_sweep_out_that_is_a_file_is_refused_as_the_command_line_refuses_it(scenario, monkeypatch):
    """cpf.sweep(out=<a file>) raised a raw NotADirectoryError (found by a new user): the command line's check."""
    (scenario.parent / "a_file").write_text("")
    done = cpf_command("sweep", scenario.name, "--param", "comms.loss=0.1", "--out", "a_file", cwd=scenario.parent)
    said = [line.split("error: ", 1)[1] for line in done.stderr.splitlines() if "error: " in line]
    assert done.returncode == 2 and said == ["--out: not a directory, got a_file"]
    monkeypatch.chdir(scenario.parent)  # the file named as the command line names it
    with pytest.raises(cpf.ScenarioError) as caught:
        cpf.sweep(scenario, params={"comms.loss": [0.1]}, seeds=1, out="a_file", progress=False)
    assert caught.value.errors == said


def test_summary_is_the_metrics_json_of_cpf_report(cli_run, tmp_path):
    """Run.summary lacked metrics.json's transmissions (the books per link) and drawn_from (found by a new user):
    both come from one function now, the same dict for the same log."""
    run, _, _ = cli_run
    done = cpf_command("report", str(run.log), "--out", str(tmp_path), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    written = json.loads((tmp_path / "metrics.json").read_text())
    assert set(run.summary) == set(written) and {"transmissions", "drawn_from"} <= set(written)
    assert json.loads(json.dumps(run.summary)) == written


def test_an_interrupted_run_or_sweep_closes_its_progress_bar(scenario, monkeypatch):
    """A KeyboardInterrupt during cpf.run left its tqdm bar open (a notebook showed a ghost bar later; found by a new
    user): closed in a finally, as cpf.sweep's is. (tqdm's close sets disable.)"""
    from supervisor.engine import interrupts, progress
    from supervisor.tools import sweep

    bars, bar, steps = [], progress._bar, iter(range(20))

    def drawn(*args):
        bars.append(bar(*args))
        return bars[-1]

    def check():
        if next(steps, None) is None:  # a Ctrl-C at the 21st step
            raise KeyboardInterrupt

    monkeypatch.setattr(progress, "_bar", drawn)
    monkeypatch.setattr(interrupts, "check", check)
    with pytest.raises(KeyboardInterrupt):
        cpf.run(shortened(scenario.read_text(), 10.0), progress=True)
    assert len(bars) == 1 and bars[0].total == 10.0 and bars[0].disable

    def interrupted(*args, **kwargs):
        bars.append(args[6])  # the sweep's progress (cli.terminal.SweepBar), its bar drawn
        args[6](0, 2)
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep, "sweep", interrupted)
    with pytest.raises(KeyboardInterrupt):
        cpf.sweep(scenario, params={"comms.loss": [0.1]}, seeds=2)
    assert bars[1]._bar.total == 2 and bars[1]._bar.disable


def test_the_docs_promise_a_notebook_widget_only_with_ipywidgets():
    """tqdm.auto draws a widget in a notebook only with ipywidgets, which cpf-cosim does not require (tqdm warns,
    TqdmWarning, and draws text): the docs said "a widget in a notebook" (found by a new user)."""
    import tomllib

    root = CONFIGS.parent
    project = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    needed = [*project["dependencies"], *(d for extra in project["optional-dependencies"].values() for d in extra)]
    assert not [d for d in needed if d.lower().startswith("ipywidgets")]
    code = [root / "supervisor" / "engine" / "progress.py", root / "supervisor" / "cli" / "terminal.py"]
    for path in (root / "README.md", root / "docs" / "api.md", *(root / "cpf").glob("*.py"), *code):
        text = " ".join(path.read_text(encoding="utf-8").split())
        promises = [m.start() for m in re.finditer(r"widget", text)]
        assert all("ipywidgets" in text[max(0, at - 200) : at + 200] for at in promises), path


def test_the_package_docstring_loads_the_log_make_run_writes():
    makefile = (CONFIGS.parent / "Makefile").read_text(encoding="utf-8")
    out = re.search(r"(?m)^OUT \?= (\S+)$", makefile)
    assert out is not None and "--out $(OUT)/run.mcap" in makefile
    assert f'cpf.load("{out[1]}/run.mcap")' in (cpf.__doc__ or "")


def test_sweep_times_never_reached_are_float_nan(scenario, tmp_path):
    """sync_time and resync_time came as object columns of None where a run never settled (or had no fault to settle
    after): float NaN now, as pandas reads results.csv, whose empty fields stay as they were."""
    short = tmp_path / "sweep.toml"
    short.write_text(shortened(scenario.read_text(), 5.0))
    table = cpf.sweep(short, params={"comms.loss": [0.1, 0.3]}, seeds=1, out=tmp_path / "s", progress=False)
    written = pd.read_csv(tmp_path / "s" / "results.csv")
    for name in ("sync_time", "resync_time"):
        assert table[name].dtype == np.float64 == written[name].dtype and table[name].isna().all(), name
    measured = [c for c in written.columns if c not in ("comms.loss", "seed", "sent", "delivered", "dropped")]
    assert (table[measured].dtypes == np.float64).all()
    header, *rows = (tmp_path / "s" / "results.csv").read_text().splitlines()
    at = header.split(",").index("sync_time")
    assert header.split(",")[at + 1] == "resync_time"
    assert [row.split(",")[at : at + 2] for row in rows] == [["", ""], ["", ""]]  # None: empty, as it was

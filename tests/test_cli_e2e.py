"""`cpf` run as a user would: a console command, its output, its files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from supervisor.record.recorder import read_messages
from tests.conftest import link_events, shortened

pytestmark = pytest.mark.e2e
CPF = Path(sys.executable).parent / "cpf"


def cpf(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(CPF), *args], cwd=cwd, capture_output=True, text=True, timeout=300)


def test_run_then_report_a_shortened_paper_scenario(tmp_path, paper_text):
    from supervisor.analysis.figures_nav import has_navigation
    from supervisor.analysis.rundata import load_run

    scenario = tmp_path / "short.toml"
    scenario.write_text(shortened(paper_text, 170.0))
    done = cpf("run", str(scenario), "--engine", "inprocess", "--out", "out/run.mcap", "--quiet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "before faults" in done.stdout and "during speed_cap" in done.stdout
    assert "coordination error below 0.01 from t = " in done.stdout

    with (tmp_path / "out/run.mcap").open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None  # the file ends with summary and index
        counts = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
        encodings = {ch.message_encoding for ch in summary.channels.values()}
        schema_encodings = {s.encoding for s in summary.schemas.values()}
    expected = {"cpf/run/meta": 1, "cpf/run/graph": 1, "cpf/run/fault": 1}
    for vid in (1, 2, 3):
        expected |= {f"cpf/vehicle/{vid}/{leaf}": 1700 for leaf in ("state", "tx", "rx")}
    assert {topic: counts[topic] for topic in expected} == expected
    assert counts["cpf/comms/events"] == 1700  # a batch a step: 4 directed links, sent + delivered each step
    assert len(link_events(read_messages(tmp_path / "out" / "run.mcap"))) == 4 * 1700 * 2
    assert encodings == {"json"} and schema_encodings == {"jsonschema"}

    report = cpf("report", "out/run.mcap", "--out", "figs", cwd=tmp_path)
    assert report.returncode == 0, report.stderr
    for name in ("fig3_trajectories.png", "fig4_path_following_errors.png", "fig5_coordination_errors.png"):
        data = (tmp_path / "figs" / name).read_bytes()
        assert data.startswith(b"\x89PNG") and len(data) > 10_000
    # A run without navigation: no navigation figure, no navigation metrics (tests/test_navigation.py has the other).
    assert not (tmp_path / "figs" / "navigation_errors.png").exists()
    assert "navigation" not in json.loads((tmp_path / "figs" / "metrics.json").read_text())
    assert not has_navigation(load_run(tmp_path / "out/run.mcap"))


def test_report_of_a_missing_log_is_a_one_line_error(tmp_path):
    done = cpf("report", "nope.mcap", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["cpf: error: nope.mcap: no such log file"]


def test_run_metrics_json_says_what_the_printed_summary_says(tmp_path, paper_text):
    from supervisor.analysis.input_limits import percent

    scenario = tmp_path / "short.toml"
    scenario.write_text(shortened(paper_text, 60.0) + "\n[comms]\nloss = 0.3\n")
    args = ["run", str(scenario), "--engine", "inprocess", "--out", "m.mcap", "--metrics", "out/m.json", "--quiet"]
    done = cpf(*args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    metrics = json.loads((tmp_path / "out/m.json").read_text())
    # malformed, dropped_by_cause: the Zenoh engine's readers' drops; none here, the same keys (a new user diffed the
    # two engines' files)
    keys = {"coordination", "comms", "links", "inputs_at_limit", "divergence", "malformed", "dropped_by_cause"}
    assert set(metrics) == keys and metrics["malformed"] == metrics["dropped_by_cause"] == {}
    for vehicle, limits in metrics["inputs_at_limit"].items():  # issue 24: the seconds each input sat at its limit
        shares = [f"{name} {percent(limits[name] / limits['alive'])}" for name in ("surge", "pitch", "yaw")]
        said = [share for share, name in zip(shares, ("surge", "pitch", "yaw"), strict=True) if limits[name] > 0]
        if said:
            assert f"vehicle {vehicle}: inputs at their limits for {', '.join(said)} of its time" in done.stdout
    coordination = metrics["coordination"]
    assert [p["name"] for p in coordination["phases"]] == ["whole run"]
    assert f"max {coordination['max_path_error_after_transient']:.3f} m" in done.stdout
    links = metrics["links"]
    assert links["sent"] == links["delivered"] + links["dropped"] and links["dropped"] > 0
    rows = metrics["comms"]["links"]
    assert {(r["sender"], r["receiver"]) for r in rows} == {(1, 2), (2, 1), (1, 3), (3, 1)}
    assert sum(r["sent"] for r in rows) == links["sent"]

"""`cpf resim` applies only settings that act inside a vehicle; any other --set is refused (exit 2, one line naming
the key and value and why), never silently ignored (supervisor/engine/resim_settings.py, supervisor/engine/resim.py)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from supervisor import cli
from supervisor.config.scenario import parse_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.engine.resim import resimulate
from supervisor.engine.resim_settings import SETTINGS, check_override
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS, shortened

DURATION = 20.0

REFUSED = [
    "comms.loss=0.5",
    "comms.transmit.period=1.0",
    "comms.transmit.policy=event",
    "comms={loss=0.5}",
    "graph.edges=[[1,2],[2,3]]",
    "faults.0.start=1",
    "scenario.step=0.05",
    "scenario.seed=4",
    "scenario.dimension=2",
    "vehicles.0.id=9",
    "scenario.duration=500",
    "coordinationx.k=1",
]
APPLIED = [
    "coordination.k=0.05",
    "coordination={k=0.05}",
    "path_following.k1=0.8",
    "vehicles.1.gamma0=0.5",
    "report.transient=5",
    "scenario.duration=10",
]


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    text = shortened((CONFIGS / "paper.toml").read_text(), DURATION)
    scenario = parse_scenario(text, "configs/paper.toml", ["faults.0.start=3", "faults.0.end=6", "comms.loss=0.3"])
    path = tmp_path_factory.mktemp("resim") / "run.mcap"
    run_inprocess(scenario, "configs/paper.toml", text, path, 1, Progress(DURATION, io.StringIO(), enabled=False))
    return path


@pytest.mark.parametrize("override", REFUSED)
def test_a_setting_resim_cannot_apply_is_refused_on_one_line(
    override: str, log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "resim.mcap"
    code = cli.main(["resim", str(log), "--set", override, "--out", str(out)])
    captured = capsys.readouterr()
    assert code == cli.EXIT_INPUT, captured.out
    assert captured.out == "" and not out.exists()  # nothing printed as results, nothing written
    [line] = captured.err.splitlines()
    assert line.startswith(f"cpf: error: {log}: --set {override}: resim cannot apply it (")


def test_a_longer_duration_says_how_long_the_run_was(log: Path) -> None:
    with pytest.raises(ScenarioError, match=r"recorded only 20 s: no receptions after that"):
        resimulate(log, ["scenario.duration=500"], log.with_name("long.mcap"))


@pytest.mark.parametrize("override", APPLIED)
def test_a_vehicle_setting_is_applied(override: str, log: Path, tmp_path: Path) -> None:
    sc, original, new, _ = resimulate(log, [override], tmp_path / "resim.mcap")
    assert np.isfinite(new.gamma).all() and np.isfinite(original.gamma).all()  # no nan rows
    if override.startswith(("coordination", "path_following", "vehicles")):
        assert not np.array_equal(new.gamma, original.gamma)  # it acted
    if override == "scenario.duration=10":
        assert sc.scenario.duration == 10 and new.gamma.shape[0] == 100
        np.testing.assert_array_equal(new.gamma, original.gamma)  # the start of the run, as it was


def test_the_help_lists_every_setting_of_the_table(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        cli.main(["resim", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for pattern, _ in SETTINGS:
        assert pattern.replace("#", "N") in text
    assert "comms.*" in text and "refused" in text


def test_the_table_accepts_keys_at_and_below_its_places() -> None:
    for key in ("coordination", "coordination.k", "vehicles.12.path.radius", "vehicles.0.path", "vehicle.overrides.m"):
        check_override(Path("run.mcap"), f"{key}=1")
    for key in ("vehicles.0", "vehicles.x.gamma0", "vehicles", "path_followingx", "report2.transient"):
        with pytest.raises(ScenarioError, match=f"--set {key}=1: resim cannot apply it"):
            check_override(Path("run.mcap"), f"{key}=1")

"""Input that used to be accepted silently: refused before anything starts (exit 2, one line each), or a warning
where the run still makes sense.

    vehicle 2 ---- vehicle 1 ---- vehicle 3        (the paper's graph: there is no link 2 - 3)
"""

from __future__ import annotations

from pathlib import Path

import pytest

from supervisor.cli import main
from supervisor.config.derived import active
from supervisor.config.scenario import fault_table, parse_scenario
from supervisor.config.scenario_checks import scenario_warnings
from supervisor.errors import ScenarioError
from tests.conftest import CONFIGS
from tests.procs import cpf

PAPER = (CONFIGS / "paper.toml").read_text()
SOURCE = "s.toml"


def with_faults(*tables: str, text: str = PAPER) -> str:
    return text + "".join(f"\n[[faults]]\n{table}\n" for table in tables)


def errors_of(text: str, overrides: tuple[str, ...] = ()) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, SOURCE, overrides)
    return info.value.errors


# --- options of cpf run ---------------------------------------------------------------------------------------


@pytest.fixture
def paper_file(tmp_path: Path) -> Path:
    path = tmp_path / "paper.toml"
    path.write_text(PAPER)
    return path


OPTIONS = {
    "no such vehicle": (
        ["--remote", "2,7", "--credentials-dir", "c"],
        "--remote: no vehicle 7 in [[vehicles]] [1, 2, 3], got 7",
    ),
    "remote in process": (["--engine", "inprocess", "--remote", "2"], "--remote: only the zenoh engine"),
    "listen in process": (["--engine", "inprocess", "--listen", "tcp/127.0.0.1:7447"], "--listen: only the zenoh"),
    "connect in process": (["--engine", "inprocess", "--connect", "tcp/127.0.0.1:7447"], "--connect: only the zenoh"),
    "timeout in process": (["--engine", "inprocess", "--start-timeout", "5"], "--start-timeout: only the zenoh"),
    "max window in process": (["--engine", "inprocess", "--max-window", "2"], "--max-window: only the zenoh engine's"),
    "max window in realtime": (
        ["--clock", "realtime", "--max-window", "1"],
        "--max-window: only the zenoh engine's lockstep clock has time windows, got 1",
    ),
    "speed in lockstep": (["--speed", "2"], "--speed: only the realtime clock is paced (add --clock realtime), got 2"),
    "a remote vehicle killed": (
        ["--remote", "2", "--credentials-dir", "c", "--fault", "kind=vehicle_kill,vehicle=2,start=1,end=2"],
        "--remote: faults[1] kills vehicle 2, which the supervisor cannot do",
    ),
}


@pytest.mark.parametrize(("options", "expected"), list(OPTIONS.values()), ids=list(OPTIONS))
def test_an_option_that_cannot_do_what_it_says_is_refused_before_anything_starts(
    options: list[str], expected: str, paper_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = paper_file.parent / "never.mcap"
    assert main(["run", str(paper_file), "--out", str(out), "--quiet", *options]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"cpf: error: {paper_file}: {expected}"), lines
    assert not out.exists()  # nothing half-done


def test_every_bad_option_is_reported_at_once(paper_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    options = ["--engine", "inprocess", "--remote", "9", "--speed", "3"]
    assert main(["run", str(paper_file), "--out", str(paper_file.parent / "x.mcap"), *options]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(": ")[3] for line in lines] == ["--remote", "--remote", "--speed"], lines


def test_speed_with_the_realtime_clock_is_accepted() -> None:
    from argparse import Namespace

    from supervisor.cli import _option_errors

    scenario = parse_scenario(PAPER)
    args = Namespace(
        remote=(2, 3), engine="zenoh", listen=None, connect=None, start_timeout=5.0, speed=2.0, max_window=None
    )
    args.credentials_dir, args.zenoh_config = Path("creds"), None  # vehicles started by hand get credentials
    assert _option_errors(Namespace(**vars(args), clock="realtime"), scenario) == []


# --- scenario rules -----------------------------------------------------------------------------------------

LINK_DOWN_23 = 'kind = "link_down"\nsender = 2\nreceiver = 3\nstart = {start}\nend = {end}'
SWITCH_TO_CHAIN = 'kind = "graph_switch"\nedges = [[1, 2], [2, 3]]\nstart = 100.0\nend = 200.0'


def test_a_link_fault_on_a_link_never_in_the_graph_is_refused() -> None:
    text = with_faults(LINK_DOWN_23.format(start=10.0, end=20.0))
    assert errors_of(text) == [f"{SOURCE}: faults[1]: not a link of the graph while the fault acts, got 2 -> 3"]
    degraded = with_faults('kind = "link_degraded"\nsender = 3\nreceiver = 2\nstart = 1.0\nextra_loss = 0.5')
    assert errors_of(degraded) == [f"{SOURCE}: faults[1]: not a link of the graph while the fault acts, got 3 -> 2"]


def test_a_link_fault_on_a_link_a_graph_switch_puts_in_force_while_it_acts_is_accepted() -> None:
    during = with_faults(SWITCH_TO_CHAIN, LINK_DOWN_23.format(start=150.0, end=300.0))
    assert [f.kind for f in parse_scenario(during).faults] == ["speed_cap", "graph_switch", "link_down"]
    after = with_faults(SWITCH_TO_CHAIN, LINK_DOWN_23.format(start=200.0, end=300.0))  # the switch is over at 200
    assert errors_of(after) == [f"{SOURCE}: faults[2]: not a link of the graph while the fault acts, got 2 -> 3"]


def test_transmission_settings_that_cannot_be_kept_and_a_link_given_twice_are_refused() -> None:
    """Each was accepted and not done (found by a new user): a period shorter than the step (described as 'every
    0.05 s', sent every step), a heartbeat shorter than min_interval (min_interval won), two [[comms.links]] entries
    for one link (one of them ignored)."""
    assert errors_of(PAPER, ("comms.transmit.period=0.05",)) == [
        f"{SOURCE}: comms.transmit.period: at least the step (0.1 s): one message a step at most, got 0.05"
    ]
    event = ("comms.transmit.policy=event", "comms.transmit.heartbeat=1.0", "comms.transmit.min_interval=5.0")
    assert errors_of(PAPER, event) == [f"{SOURCE}: comms.transmit.heartbeat: at least min_interval (5 s), got 1.0"]
    twice = ("comms.links=[{sender=1,receiver=2,loss=0.1},{sender=1,receiver=2,loss=0.5}]",)
    assert errors_of(PAPER, twice) == [f"{SOURCE}: comms.links[1]: the same link as comms.links[0], got 1 -> 2"]
    assert parse_scenario(PAPER, SOURCE, ("comms.transmit.period=0.1",)).comms.transmit.period == 0.1


def test_transmission_times_off_the_step_grid_are_refused() -> None:
    """Vehicles decide on the step grid: a period of 0.15 s at a 0.1 s step sent after 1 or 2 steps as each time
    stamp rounded (421 messages in 60 s, not ~400; found by a new user). Whole numbers of steps, as a TDMA slot."""
    assert errors_of(PAPER, ("comms.transmit.period=0.15",)) == [
        f"{SOURCE}: comms.transmit.period: must be a whole number of steps (0.1 s), got 0.15"
    ]
    event = ("comms.transmit.policy=event", "comms.transmit.heartbeat=2.55", "comms.transmit.min_interval=0.45")
    assert errors_of(PAPER, event) == [
        f"{SOURCE}: comms.transmit.min_interval: must be a whole number of steps (0.1 s), got 0.45",
        f"{SOURCE}: comms.transmit.heartbeat: must be a whole number of steps (0.1 s), got 2.55",
    ]
    fine = ("comms.transmit.policy=event", "comms.transmit.heartbeat=0.7", "comms.transmit.min_interval=0.3")
    assert parse_scenario(PAPER, SOURCE, fine).comms.transmit.heartbeat == 0.7  # 7 and 3 steps, as floats give them
    assert parse_scenario(PAPER, SOURCE, ("comms.transmit.period=2.3",)).comms.transmit.period == 2.3


def test_a_fault_spec_that_gives_a_key_twice_is_refused() -> None:
    """--fault kind=blackout,start=1,start=2 kept the last start (TOML refuses a key given twice)."""
    with pytest.raises(ScenarioError, match=r"^--fault start: given twice, got 'kind=blackout,start=1,start=2'$"):
        fault_table("kind=blackout,start=1,start=2")


def test_a_fault_that_ends_within_the_step_it_starts_in_is_refused() -> None:
    text = with_faults('kind = "blackout"\nstart = 10.0\nend = 10.04')  # step 0.1 s
    assert errors_of(text) == [f"{SOURCE}: faults[1].end: ends within the step it starts in (0.1 s), got 10.04"]


def kill(kind: str, start: float, end: float | None = None, vehicle: int | None = 2) -> str:
    table = f'kind = "{kind}"\nstart = {start}' + (f"\nend = {end}" if end is not None else "")
    return table + (f"\nvehicle = {vehicle}" if kind == "vehicle_kill" else "")


def test_kills_of_one_process_that_overlap_or_meet_are_refused() -> None:
    """The first kill's end restarted the process while the second should hold it down (the broker delivered
    packets in its second kill; over Zenoh the run timed out): found by a new user, refused now."""
    overlapping = with_faults(kill("vehicle_kill", 1.0, 5.0), kill("vehicle_kill", 3.0, 8.0))
    assert errors_of(overlapping) == [
        f"{SOURCE}: faults[2]: a vehicle_kill of vehicle 2 that overlaps or meets faults[1] ([1, 5) s): a process is "
        "killed once at a time (make them one fault), got [3, 8) s"
    ]
    meeting = with_faults(kill("broker_kill", 4.0, 6.0), kill("broker_kill", 6.0))
    assert errors_of(meeting) == [
        f"{SOURCE}: faults[2]: a broker_kill of the comms broker that overlaps or meets faults[1] ([4, 6) s): a "
        "process is killed once at a time (make them one fault), got [6, 6.1) s"
    ]
    apart = [kill("vehicle_kill", 1.0, 5.0), kill("vehicle_kill", 5.1, 8.0), kill("vehicle_kill", 3.0, vehicle=3)]
    assert len(parse_scenario(with_faults(*apart)).faults) == 4  # a step apart, or another vehicle: both fine


def test_a_vehicle_killed_from_the_first_step_cannot_be_restarted() -> None:
    """It resumes from its last state and had none (a KeyError on both engines at the restart)."""
    assert errors_of(with_faults(kill("vehicle_kill", 0.0, 5.0))) == [
        f"{SOURCE}: faults[1].end: a vehicle_kill from the first step cannot end: the restarted vehicle resumes from "
        "its last state and has none (start it at 0.1 s or later, or leave out end), got 5.0"
    ]
    assert len(parse_scenario(with_faults(kill("vehicle_kill", 0.0))).faults) == 2  # killed for good: fine


def test_a_fault_after_the_end_of_the_run_is_a_warning_not_an_error() -> None:
    """A shortened run of a longer scenario is a fair request: the run makes sense, the fault just never acts."""
    scenario = parse_scenario(with_faults('kind = "blackout"\nstart = 400.0'), overrides=("scenario.duration=100",))
    assert scenario_warnings(scenario) == [
        "faults[0].start: at or after the end of the run (100 s), the speed_cap fault never acts, got 150.0",
        "faults[1].start: at or after the end of the run (100 s), the blackout fault never acts, got 400.0",
    ]
    assert scenario_warnings(parse_scenario(PAPER)) == []


def test_cpf_run_prints_the_warning(paper_file: Path) -> None:
    args = ["--engine", "inprocess", "--set", "scenario.duration=0.5", "--out", "short.mcap", "--quiet"]
    done = cpf("run", str(paper_file), *args, cwd=paper_file.parent)
    assert done.returncode == 0, done.stderr
    assert done.stderr.splitlines() == [
        f"cpf run: {paper_file}: faults[0].start: at or after the end of the run (0.5 s), the speed_cap fault "
        "never acts, got 150.0"
    ]


@pytest.mark.parametrize("step", ["0.3", "0.15", "7.0"])
def test_a_step_that_does_not_divide_the_duration_is_refused(step: str) -> None:
    (line,) = errors_of(PAPER, (f"scenario.step={step}",))
    assert line.startswith(f"{SOURCE}: scenario.step: must divide duration (400.0) into whole steps"), line
    assert line.endswith(f"got {step}"), line


@pytest.mark.parametrize("step", ["0.1", "0.05", "0.2", "400.0"])
def test_a_step_that_divides_the_duration_is_accepted(step: str) -> None:
    assert parse_scenario(PAPER, overrides=(f"scenario.step={step}", "faults=[]")).scenario.step == float(step)


# --- dimension 2 ----------------------------------------------------------------------------------------------

PLANAR = ("scenario.dimension=2",)
FLAT = tuple(f"vehicles.{i}.{key}" for i in range(3) for key in ("path.climb=0.0", "position.2=0.0"))


def test_the_planar_model_refuses_a_climbing_helix() -> None:
    errors = errors_of(PAPER, PLANAR)
    assert errors == [
        f"{SOURCE}: vehicles[{i}].path.climb: dimension 2 (planar) keeps every vehicle in its path's horizontal "
        "plane (no climb), got 0.05"
        for i in range(3)
    ]


def test_the_planar_model_refuses_a_vehicle_off_its_paths_plane_and_motion_out_of_the_plane() -> None:
    overrides = (*PLANAR, *FLAT, "vehicles.0.position.2=-5.0", "vehicles.1.velocity=[1.0, 0.0, 0.2]")
    assert errors_of(PAPER, (*overrides, "vehicles.2.attitude_rpy_deg=[0.0, 10.0, 45.0]")) == [
        f"{SOURCE}: vehicles[0].position: dimension 2 (planar) keeps every vehicle in its path's horizontal plane "
        "(z = 0), got z = -5.0",
        f"{SOURCE}: vehicles[1].velocity: dimension 2 (planar) has no w, got [0.2]",
        f"{SOURCE}: vehicles[2].attitude_rpy_deg: dimension 2 (planar) has no roll, pitch, got [0.0, 10.0]",
    ]


def test_the_planar_model_refuses_a_line_that_dives() -> None:
    line = "vehicles.0.path={type = 'line', start = [0.0, 0.0, 0.0], velocity = [1.0, 0.0, -0.1]}"
    errors = errors_of(PAPER, (*PLANAR, *FLAT, line, "vehicles.0.position.2=0.0"))
    assert errors == [
        f"{SOURCE}: vehicles[0].path.velocity: dimension 2 (planar) keeps every vehicle in its path's horizontal "
        "plane (no climb), got -0.1"
    ]


def test_the_planar_model_takes_flat_paths_at_any_depth() -> None:
    deep = tuple(f"vehicles.{i}.{key}" for i in range(3) for key in ("path.center=[0.0, 0.0, -10.0]",))
    moved = tuple(f"vehicles.{i}.position.2=-10.0" for i in range(3))
    no_climb = tuple(f"vehicles.{i}.path.climb=0.0" for i in range(3))
    assert parse_scenario(PAPER, overrides=(*PLANAR, *FLAT)).scenario.dimension == 2  # helices that do not climb
    scenario = parse_scenario(PAPER, overrides=(*PLANAR, *no_climb, *deep, *moved))
    assert [v.position[2] for v in scenario.vehicles] == [-10.0] * 3


@pytest.mark.parametrize(("value", "shown"), [('"oops"', "'oops'"), ("3", "3")])
def test_faults_that_are_not_an_array_with_a_fault_option_are_an_error_not_a_traceback(value, shown) -> None:
    """`--set faults="oops" --fault kind=blackout,start=5` was an AttributeError (exit 1) appending to the string."""
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(PAPER, SOURCE, (f"faults={value}",), ("kind=blackout,start=5",))
    assert caught.value.errors == [f"{SOURCE}: faults: must be an array, got {shown}"]


def test_a_fault_acting_on_no_step_gets_one_error_and_one_within_a_step_acts_on_its_nearest() -> None:
    """Start and end are each rounded to the nearest step (the README): [100, 100.05) acts on none (one error; a
    second said 1 -> 2 was not a link of the graph, found by a new user), [100.02, 100.08) on the step from 100."""
    link = 'kind = "link_down"\nsender = 1\nreceiver = 2\nstart = {start}\nend = {end}'
    text = with_faults(link.format(start=100.0, end=100.05))
    assert errors_of(text) == [f"{SOURCE}: faults[1].end: ends within the step it starts in (0.1 s), got 100.05"]
    (_, fault) = parse_scenario(with_faults(link.format(start=100.02, end=100.08))).faults
    assert [k for k in (999, 1000, 1001) if active(fault, k * 0.1, 0.1)] == [1000]


def test_a_key_of_another_transmission_policy_is_a_warning_naming_it() -> None:
    """Both built-in policies' keys sit in [comms.transmit]: one the policy does not read was silently ignored (QA
    report 2, F6). A key written counts, even at its default (threshold 0.05): the user expects it to act."""

    def said(*overrides: str) -> list[str]:
        return [w for w in scenario_warnings(parse_scenario(PAPER, SOURCE, overrides)) if "transmit" in w]

    periodic = ("comms.transmit.period=1.0", "comms.transmit.heartbeat=0.5", "comms.transmit.threshold=0.05")
    assert said(*periodic) == [
        "comms.transmit.threshold: a key of the event policy, it has no effect under policy 'periodic', got 0.05",
        "comms.transmit.heartbeat: a key of the event policy, it has no effect under policy 'periodic', got 0.5",
    ]
    assert said("comms.transmit.policy=event", "comms.transmit.period=1.0", "comms.transmit.heartbeat=2.0") == [
        "comms.transmit.period: a key of the periodic policy, it has no effect under policy 'event', got 1.0"
    ]
    assert said("comms.transmit.policy=tests.samples.laws:Every", "comms.transmit.period=1.0") == [
        "comms.transmit.period: a key of the periodic policy, it has no effect under policy "
        "'tests.samples.laws:Every' (it reads only comms.transmit.options), got 1.0"
    ]
    event = ("comms.transmit.policy=event", "comms.transmit.threshold=0.1", "comms.transmit.min_interval=1.0")
    assert said(*event) == said("comms.transmit.period=1.0") == []


def test_validate_says_the_ignored_transmission_key(paper_file: Path, caplog: pytest.LogCaptureFixture) -> None:
    assert main(["validate", str(paper_file), "--set", "comms.transmit.heartbeat=0.5"]) == 0
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert warned == [
        f"{paper_file}: comms.transmit.heartbeat: a key of the event policy, it has no effect under policy "
        "'periodic', got 0.5"
    ]

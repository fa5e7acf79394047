"""Lockstep time windows give the run one step at a time gives, record for record: the Zenoh engine with windows,
the Zenoh engine forced to one step per window (a bus round trip per step, as before windows) and the in-process
engine, on every transmission policy (periodic slower than the step, event-triggered with a minimum interval and a
heartbeat, every step held for its TDMA slot), an acoustic channel whose packets take several steps, and faults of
every kind with a vehicle killed and restarted and the broker killed and restarted; and slow links whose packets
take longer than the fleet waits between transmissions, where windows run past the transmissions (channel
lookahead, comms.broker.lookahead), with and without collisions. The windows are really taken: the clock's ticks on
the bus and the vehicles' window messages are counted (spies on Clock._publish and the intake)."""

from __future__ import annotations

import io
from pathlib import Path

import pytest

from supervisor.config.scenario import parse_scenario
from supervisor.engine import intake as intake_module
from supervisor.engine.clock import Clock
from supervisor.engine.cosim import BusOptions, run_zenoh
from supervisor.engine.inprocess import RunResult, run_inprocess
from supervisor.engine.intake import Intake
from supervisor.engine.progress import Progress
from supervisor.plan.schedule import StepPlan
from tests.conftest import CONFIGS, shortened
from tests.procs import processes_with
from tests.test_faults_e2e import EVERY_KIND, assert_balanced, read_run, records

pytestmark = pytest.mark.e2e

PERIODIC = ["comms.transmit.period=1.0"]
SLOW = ["comms.bitrate=60"]
CASES: dict[str, tuple[str, float, list[str], list[str]]] = {  # name -> (scenario, duration, --set, --fault)
    "periodic, every fault kind": (
        "paper.toml", 60.0, [*PERIODIC, "scenario.on_vehicle_loss=continue", "faults.0.start=3", "faults.0.end=9"],
        EVERY_KIND,
    ),
    "event-triggered": (
        "paper.toml", 40.0,
        ["comms.transmit.policy=event", "comms.transmit.min_interval=0.7", "comms.transmit.heartbeat=3.0",
         "faults.0.start=10", "faults.0.end=20"],
        [],
    ),
    "tdma": ("paper.toml", 30.0, ["comms.tdma.slot=0.4", "faults.0.start=10", "faults.0.end=20"], []),
    # channel lookahead (comms.broker.lookahead): 2 s on the air per packet (15 B at 60 bit/s), no collisions, so
    # a window runs past the fleet's transmissions for up to 2 s
    "slow links, every step": ("paper.toml", 30.0, [*SLOW, "faults.0.start=10", "faults.0.end=20"], []),
    "slow links, every fault kind": (
        "paper.toml", 60.0,
        [*SLOW, "comms.transmit.period=0.5", "scenario.on_vehicle_loss=continue", "faults.0.start=3",
         "faults.0.end=9"],
        EVERY_KIND,
    ),
    "slow links, collisions, jitter, bursts": (
        "paper.toml", 40.0,
        [*SLOW, "comms.collisions=true", "comms.half_duplex=true", "comms.transmit.policy=event",
         "comms.transmit.min_interval=0.3", "comms.jitter=0.05", "comms.burst.mean_loss=0.05",
         "comms.burst.mean_burst=2.0", "faults.0.start=10", "faults.0.end=20"],
        [],
    ),
    "delayed links, every step": (  # the ideal modem, each link an extra delay (the least 1.5 s), one degraded
        "paper.toml", 40.0,
        ["comms.links=[{sender=1,receiver=2,extra_delay=1.5},{sender=2,receiver=1,extra_delay=1.5},"
         "{sender=1,receiver=3,extra_delay=2.5},{sender=3,receiver=1,extra_delay=1.7}]",
         "faults.0.start=10", "faults.0.end=20"],
        ["kind=link_degraded,sender=1,receiver=3,extra_loss=0.3,extra_delay=0.4,start=22,end=31"],
    ),
    "slow links, tdma": (
        "paper.toml", 40.0, [*SLOW, "comms.tdma.slot=2.2", "comms.half_duplex=true", "faults.0.start=10",
                             "faults.0.end=20"], [],
    ),
    "acoustic, killed vehicle": (
        "paper_acoustic.toml", 40.0, ["comms.transmit.period=2.0", "scenario.on_vehicle_loss=continue"],
        ["kind=vehicle_kill,vehicle=2,start=13.3,end=17.1", "kind=broker_kill,start=25,end=26.5"],
    ),
}  # fmt: skip

# Whose windows, without lookahead, stop at transmissions at most 5 steps apart (TDMA's slots are longer).
PAST_TRANSMISSIONS = (
    "slow links, every step",
    "delayed links, every step",
    "slow links, every fault kind",
    "slow links, collisions, jitter, bursts",
)


def run(
    tmp: Path, name: str, engine: str, longest: int | None, monkeypatch: pytest.MonkeyPatch
) -> tuple[Path, RunResult, list[int]]:
    """One run of CASES[name]; the window lengths run (zenoh only): one per tick the supervisor published, and one per
    step message of a vehicle (inside a span the broker works the windows out: comms.broker.span)."""
    file, duration, overrides, faults = CASES[name]
    text = shortened((CONFIGS / file).read_text(), duration)
    path = tmp / "s.toml"
    path.write_text(text)
    scenario = parse_scenario(text, str(path), overrides, faults)
    out = tmp / f"{engine}-{longest}.mcap"
    quiet = Progress(duration, io.StringIO(), enabled=False)
    if engine == "inprocess":
        return out, run_inprocess(scenario, str(path), text, out, 0, quiet), []
    windows: list[int] = []
    publish = Clock._publish

    def counted(self: Clock, driven: object, plan: StepPlan, end: int) -> None:
        windows.append(end - plan.k)
        publish(self, driven, plan, end)  # type: ignore[arg-type]

    monkeypatch.setattr(Clock, "_publish", counted)
    take = Intake._window

    def stepped(self: Intake, vid: int, message: dict) -> None:
        windows.append(len(message.get("earlier") or []) + 1)
        take(self, vid, message)

    monkeypatch.setattr(Intake, "_window", stepped)
    read = intake_module.read_window  # the intake reads most step messages in one pass, past _window

    def read_counted(payload: bytes) -> object:
        window = read(payload)
        if window is not None:
            windows.append(len(window[0]))
        return window

    monkeypatch.setattr(intake_module, "read_window", read_counted)
    bus = BusOptions(overrides=tuple(overrides), faults=tuple(faults))
    result = run_zenoh(scenario, path, text, out, 0, "lockstep", 1.0, bus, quiet, longest)
    monkeypatch.undo()
    assert processes_with(str(path)) == []
    return out, result, windows


@pytest.mark.parametrize("name", list(CASES))
def test_windows_record_what_one_step_at_a_time_records(tmp_path, monkeypatch, name):
    windowed, windowed_result, windows = run(tmp_path, name, "zenoh", None, monkeypatch)
    stepwise, stepwise_result, steps = run(tmp_path, name, "zenoh", 1, monkeypatch)
    inprocess, inprocess_result, _ = run(tmp_path, name, "inprocess", None, monkeypatch)
    expected = records(inprocess)
    assert records(windowed) == expected
    assert records(stepwise) == expected
    assert windowed_result.stats_history == stepwise_result.stats_history == inprocess_result.stats_history
    assert windowed_result.link_counts == inprocess_result.link_counts
    assert_balanced(read_run(windowed)[1])
    n = round(CASES[name][1] / 0.1)
    assert set(steps) == {1} and len(steps) >= 2 * n + 1  # every tick, every vehicle's every step
    assert sum(windows) >= 2 * n and len(windows) < 0.9 * len(steps)  # many steps ran without the bus
    if name in PAST_TRANSMISSIONS:  # windows ran past transmissions: without lookahead none is over 5 steps
        assert max(windows) >= 15

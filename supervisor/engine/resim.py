"""Re-simulation: the vehicles' closed loops re-run against the receptions recorded in a log.

`cpf resim RUN.mcap --set KEY=VALUE ...` asks what other gains (or predictors, policies, vehicle parameters) would
have done with the very same packets: the channel is not simulated again, each vehicle hears at each step exactly
what it heard in the run. That is open loop across the fleet: the neighbours' gammas a vehicle hears are the ones
recorded, not what the re-simulated neighbours now send. `--closed-loop` (supervisor.engine.resim_loop) keeps the
channel's decisions (who heard which transmission, when) and carries the re-simulated senders' gammas instead.
Vehicles step only where they were alive in the run. With no --set, either reproduces the run's state stream exactly
(the same pure functions on the same inputs; of a realtime run, all but the lateness the wall clock measured); tests
hold it to that.

So only what acts inside a vehicle can change (supervisor.engine.resim_settings.SETTINGS, also what `cpf resim --help`
lists); a setting of the channel, the graph, the faults, the step, the seed or the fleet's shape would not act on the
recorded receptions, and is refused (ScenarioError) rather than silently ignored. The duration can only shrink:
nothing was recorded after it.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import platform
from collections.abc import Iterator, Sequence
from importlib import metadata
from pathlib import Path

from comms.records.messages import META_KEY, Message, parse_rx, state_key, vehicle_of_key
from comms.records.records import Heard
from comms.records.state import WALL_CLOCK_FIELDS, StateReport
from supervisor.analysis.series import SeriesBuilder
from supervisor.analysis.summary import Series
from supervisor.config.derived import steps_of
from supervisor.config.fleet import initial_state, radio, restarted_node, vehicle_config
from supervisor.config.scenario import apply_override, validate_data
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.resim_loop import ClosedLoop
from supervisor.engine.resim_settings import check_override
from supervisor.errors import ScenarioError
from supervisor.plan.schedule import Schedule
from supervisor.record.logfile import messages
from supervisor.record.meta import RunMeta
from supervisor.record.provenance import RESIM
from supervisor.record.recorder import Recorder
from supervisor.record.unusable import Unusable
from vehicles.runtime import NodeState
from vehicles.step import step_records

log_ = logging.getLogger("cpf")


def _check_duration(log: Path, meta: RunMeta, sc: Scenario, overrides: Sequence[str]) -> None:
    recorded = meta.duration
    if sc.scenario.duration > recorded * (1 + 1e-12):
        given = next((o for o in overrides if o.partition("=")[0].strip() == "scenario.duration"), "")
        raise ScenarioError(
            f"{log}: --set {given.strip()}: resim cannot apply it (the run recorded only {recorded:g} s: no "
            f"receptions after that); a shorter duration it can"
        )
    steps = sc.scenario.duration / sc.scenario.step
    if not math.isclose(steps, round(steps), abs_tol=1e-9):
        raise ScenarioError(
            f"{log}: --set scenario.duration={sc.scenario.duration:g}: not a whole number of steps of "
            f"{sc.scenario.step:g} s"
        )


def _load(log: Path) -> tuple[RunMeta, dict[tuple[int, int], list[Heard]], list[tuple[StateReport, Message]]]:
    """The run's metadata, the receptions per (vehicle, step), and the state messages (who was stepped when)."""
    meta: RunMeta | None = None
    heard: dict[tuple[int, int], list[Heard]] = {}
    states: list[tuple[StateReport, Message]] = []
    unusable = Unusable(log)
    for topic, _, message in messages(log):
        owned = vehicle_of_key(topic)
        try:
            if topic == META_KEY:
                meta = RunMeta.from_message(message)
            elif owned is not None and owned[1] == "rx":
                k, batch = parse_rx(message)
                heard[(owned[0], k)] = batch
            elif owned is not None and owned[1] == "state":
                states.append((StateReport.from_message(message, owned[0]), message))
        except ValueError as exc:  # named and skipped: the re-simulation goes on without that record
            unusable.skip(topic, exc)
    unusable.close()
    if meta is None:
        raise ScenarioError(f"{log}: no run metadata with the scenario in it (written by an older cpf?)")
    return meta, heard, states


def version_changes(recorded: dict[str, str]) -> list[str]:
    """'name recorded -> installed' of each package the log's meta names whose installed version differs (another
    numpy or Python may change the last bits of a re-simulation: requirements.lock pins what `make` installs)."""
    changes = []
    for name, then in sorted(recorded.items()):
        try:
            now = platform.python_version() if name == "python" else metadata.version(name)
        except metadata.PackageNotFoundError:
            now = "none"
        if now != then:
            changes.append(f"{name} {then} -> {now}")
    return changes


def scenario_of(meta: RunMeta, overrides: Sequence[str], source: str) -> Scenario:
    data = json.loads(json.dumps(meta.scenario))  # a deep copy to override
    for override in overrides:
        apply_override(data, override)
    return validate_data(data, f"{source} (--set)")


@dataclasses.dataclass(frozen=True, slots=True)
class Agreement:
    """How the re-simulated state records compare with the log's, to the bit (their JSON text, see _canonical)."""

    equal: int
    total: int
    first_difference: tuple[int, float] | None  # (vehicle, t) of the first record that differs

    def line(self) -> str:
        if self.first_difference is None:
            return f"state records identical to the log's, bit for bit: {self.equal} of {self.total}"
        vehicle, t = self.first_difference
        return (
            f"state records identical to the log's: {self.equal} of {self.total}; the first difference: vehicle "
            f"{vehicle} at t = {t:g} s"
        )


def _canonical(message: Message) -> str:
    """The record's JSON text, without what the wall clock measured (a realtime run's lateness): re-stepping gives
    the rest bit for bit, and that lateness never."""
    return json.dumps({k: v for k, v in message.items() if k not in WALL_CLOCK_FIELDS}, sort_keys=True)


def resimulate(
    log: Path, overrides: Sequence[str], out: Path, loop: ClosedLoop | None = None
) -> tuple[Scenario, Series, Series, Agreement]:
    """Re-run the log's vehicles with overrides; write their states to out. Returns (scenario, original, new, how
    the new state records agree with the log's). loop: closed loop across the fleet (module docstring)."""
    for override in overrides:
        check_override(log, override)  # before reading the log: a refusal costs nothing
    meta, heard, states = _load(log)
    changes = version_changes(meta.versions)
    if changes:
        log_.warning("%s was recorded with other versions (%s): the re-simulation may differ in its last bits",
                     log, ", ".join(changes))  # fmt: skip
    sc = scenario_of(meta, overrides, str(log))
    _check_duration(log, meta, sc, overrides)
    original, new = (SeriesBuilder(sc.vehicle_ids, steps_of(sc), sc.scenario.step) for _ in range(2))
    for report, _ in states:
        original.add(report)
    recorded = {(r.vehicle, r.k): _canonical(m) for r, m in states}
    equal, first = 0, None
    with Recorder(out) as rec:
        rec.limit(sc.scenario.duration)
        # what the re-simulation ran: its scenario and all derived from it (extensions, tube, faults), these versions
        meta = RunMeta.of(sc, meta.scenario_file, meta.scenario_toml, meta.seed, "resim", meta.clock)
        rec.write(META_KEY, 0.0, meta.to_message())
        rec.note(RESIM, {"source": str(log), "set": " ".join(f"--set {o}" for o in overrides)})  # for cpf report
        for i, t, state, report in _restep(sc, heard, set(recorded), meta.seed, loop):
            rec.write(state_key(i), t, state)
            new.add(report)
            if recorded[(i, report.k)] == _canonical(state):
                equal += 1
            elif first is None:
                first = (i, t)
    return sc, original.series(), new.series(), Agreement(equal, len(recorded), first)


def _restep(
    sc: Scenario, heard: dict[tuple[int, int], list[Heard]], stepped: set[tuple[int, int]], seed: int,
    loop: ClosedLoop | None = None,
) -> Iterator[tuple[int, float, Message, StateReport]]:  # fmt: skip
    """(vehicle, t, state message, its report) step by step, each vehicle stepped where it was in the run on what
    it heard (seed: the run's, for the vehicles' navigation noise); loop: closed loop, what it heard carrying what
    the re-simulated senders sent (supervisor.engine.resim_loop), None: as recorded."""
    schedule, dt = Schedule(sc), sc.scenario.step
    configs = {i: vehicle_config(sc, i, seed) for i in sc.vehicle_ids}
    nodes = {i: NodeState(initial_state(sc, configs[i])) for i in sc.vehicle_ids}
    radios = {i: radio(sc, i) for i in sc.vehicle_ids}
    last_state: dict[int, Message] = {}
    for k in range(schedule.steps):
        plan = schedule.plan(k)
        for i in (i for i in sc.vehicle_ids if (i, k) in stepped):
            if k > 0 and (i, k - 1) not in stepped:  # its process was restarted, as the engines do it
                nodes[i] = restarted_node(configs[i], last_state[i], nodes[i].seq, k, dt, sc.faults)
            batch, neighbours = heard.get((i, k), []), plan.network.neighbours(i)
            if loop is not None:
                batch = loop.heard(batch)
            nodes[i], out = step_records(
                configs[i], radios[i], nodes[i], k, plan.t, dt, batch, neighbours, plan.disturbance(i)
            )
            if loop is not None:
                loop.transmitted(out.transmission)
            last_state[i] = state = out.state
            yield i, plan.t, state, out.report

"""A fleet of hundreds over Zenoh (issue 26's 1000 AUVs), three limits met on the way, each a failure of the old code:
- a vehicle host's start file was named after every vehicle it serves: 150 vehicles, a name past the 255 characters
  a file name may have, and `cpf run` ended in a traceback (supervisor.processes.file_stem);
- a child handed more descriptors than the fork server's 64 (a host's credential per vehicle) made the fork fail
  with EINVAL, and every later child was spawned; now such a child alone is spawned, the limit is Linux's 253;
- Zenoh's router admits 1000 sessions by default: the last vehicle of a ring of 1000 was refused and the run timed
  out waiting for it (supervisor.engine.bus_access.session_room).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.bench_scaling import ring_scenario
from comms.bus.bus import config
from supervisor import forked
from supervisor.config.scenario import parse_scenario
from supervisor.config.vehicle_start import vehicle_starts
from supervisor.engine.bus_access import SPARE_SESSIONS, run_access, session_room
from supervisor.engine.hosting import host_name
from supervisor.engine.launch import BusOptions, Launch
from supervisor.processes import ProcessGroup, file_stem

pytestmark = pytest.mark.e2e


def test_a_host_of_many_vehicles_gets_its_start_file(tmp_path: Path) -> None:
    sc = parse_scenario(ring_scenario(300, 1.0), "ring.toml")
    ids = tuple(range(1, 151))
    launch = Launch(tmp_path / "ring.toml", "tcp/127.0.0.1:1", BusOptions(), 0, tmp_path)
    handed = launch.handover(host_name(ids), vehicle_starts(sc, ids, seed=0))
    assert Path(handed[1]).exists() and len(Path(handed[1]).name) <= 64 + len(".start")
    other = launch.handover(host_name(tuple(range(151, 301))), vehicle_starts(sc, tuple(range(151, 301)), seed=0))
    assert other[1] != handed[1]  # a digest of the whole name: two hosts never share a file
    assert file_stem("vehicle 7") == "vehicle-7"  # a short name as it was


def test_a_child_with_more_descriptors_than_a_message_passes_is_spawned_and_the_next_one_forked(
    paper_text: str,
) -> None:
    first = os.memfd_create("paper.toml")
    os.write(first, paper_text.encode())
    many = (first, *(os.dup(first) for _ in range(forked.MAX_FDS)))
    validate = [sys.executable, "-P", "-m", "supervisor.cli", "validate", f"/proc/self/fd/{first}"]
    fds = {"many": many, "one": (first,)}
    try:
        with ProcessGroup(fds_of=lambda name: fds[name], fork="validate") as group:
            spawned = group.spawn("many", validate)
            then = group.spawn("one", validate)
            assert spawned.process.wait(timeout=60) == 0 and then.process.wait(timeout=60) == 0
            assert isinstance(spawned.process, subprocess.Popen)  # (its descriptors do not fit in one message)
            assert isinstance(then.process, forked.ForkedProcess)  # the fork server still serves
    finally:
        for fd in many:
            os.close(fd)


def test_the_router_admits_a_session_per_vehicle_past_zenohs_thousand() -> None:
    assert session_room(3) == {} and session_room(1000 - 1 - SPARE_SESSIONS) == {}  # small fleets: Zenoh's own
    assert session_room(1000) == {"transport/unicast/max_sessions": 1000 + 1 + SPARE_SESSIONS}
    sc = parse_scenario(ring_scenario(1000, 1.0), "ring.toml")
    with run_access(sc, BusOptions(), "tcp/127.0.0.1:1") as access:
        router = config("router", ["tcp/127.0.0.1:1"], extras=access.router)
        assert router.get_json("transport/unicast/max_sessions") == "1065"  # (JSON text)

"""A vehicle host: one OS process serving several vehicles, each as a vehicle process would (vehicles.node).

Each vehicle keeps its own Zenoh session, opened with its own credential: its own keys, liveliness token, hello and
messages, so neither the router's access control nor the log can tell a hosted vehicle from one in a process of its
own. Each is served by its own thread, running comms.bus.bus.serve as a lone vehicle's main thread would: its messages
go out in its own order, whatever its host-mates do (the GIL has them step one after another; none waits on another's
queue). The process pays its interpreter and imports once for all of them.

The supervisor holds the write end of a control pipe (CONTROL_ENV names the read end): a line `kill N` stops serving
vehicle N alone, as its SIGKILL would (no end-of-run report, its token gone, its session closed); its host-mates go on.
The host's lifeline (comms.bus.lifeline) ends every vehicle; the process ends when its last vehicle has.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable, Mapping

from comms.bus.bus import Ending
from comms.bus.lifeline import Lifeline, watch

CONTROL_ENV = "CPF_HOST_CONTROL"  # the file descriptor of the control pipe's read end
log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)

Serve = Callable[[Ending], int]  # serves one vehicle until it ends (vehicles.node.run_vehicle, its ending given)


def run_host(name: str, vehicles: Mapping[int, Serve]) -> int:
    """Serve every vehicle (by id) in a thread of its own until each has ended; exit code 0, or 1 if one failed."""
    endings = {vid: Ending() for vid in vehicles}
    lifeline = watch(name)
    if lifeline is not None:
        threading.Thread(target=_end_all_when_cut, args=(lifeline, endings), name="host-lifeline", daemon=True).start()
    control = os.environ.pop(CONTROL_ENV, None)
    if control is not None and control.isdigit():
        threading.Thread(target=_obey, args=(int(control), endings), name="host-control", daemon=True).start()
    failed: list[int] = []
    threads = [
        threading.Thread(target=_serve_one, args=(vid, serve, endings[vid], failed), name=f"vehicle-{vid}")
        for vid, serve in vehicles.items()
    ]
    for thread in threads:
        thread.start()
    try:
        for thread in threads:
            thread.join()
    except BaseException:  # Ctrl-C or SIGTERM reach the main thread only: every vehicle stops, then the process
        for ending in endings.values():
            ending.set()
        for thread in threads:
            thread.join()
        raise
    return 1 if failed else 0


def _serve_one(vid: int, serve: Serve, ending: Ending, failed: list[int]) -> None:
    """One vehicle's life; a failure ends it alone (its session closes, so the supervisor sees its token go), and
    the host's stderr says why."""
    try:
        serve(ending)
    except Exception as exc:  # any failure of this vehicle is its own, not its host-mates'
        failed.append(vid)
        log.error("vehicle %d stopped: %s: %s", vid, type(exc).__name__, exc)


def _end_all_when_cut(lifeline: Lifeline, endings: Mapping[int, Ending]) -> None:
    lifeline.cut.wait()
    for ending in endings.values():
        ending.set()


def _obey(fd: int, endings: Mapping[int, Ending]) -> None:
    """The supervisor's orders, a line each, until it closes the pipe."""
    with os.fdopen(fd, "r", encoding="ascii", errors="replace") as orders:
        for line in orders:
            order = parse_order(line, endings)
            if order is not None:
                endings[order].set()
            else:
                log.warning("vehicle host: an order it does not understand: %r", line.strip()[:80])


def parse_order(line: str, endings: Mapping[int, object]) -> int | None:
    """The vehicle a `kill N` line names, if this host serves it; None for anything else."""
    words = line.split()
    if len(words) == 2 and words[0] == "kill" and words[1].isdigit() and int(words[1]) in endings:
        return int(words[1])
    return None

"""How the Zenoh supervisor starts its children: the bus options of a run and the command line of each process.

Every child runs `python -m supervisor.cli comms|vehicle` on the supervisor's scenario file with the run's --set and
--fault, and is handed what it serves (--plan: a private file of the run, comms.bus.handover), so it starts without
validating the scenario again: ~15 MB and ~0.1 s of CPU less per process. Its hello still answers with the
supervisor's digests (supervisor.engine.startup), as a process started by hand answers with its own.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from comms.broker.broker_start import BrokerStart
from comms.bus.handover import write_private
from supervisor.processes import file_stem
from vehicles.start import VehicleStart

START_TIMEOUT = 60.0  # s for a process to declare its liveliness token (cpf run --start-timeout)


class BusOptions:
    def __init__(
        self,
        listen: str | None = None,
        connect: str | None = None,
        remote: tuple[int, ...] = (),
        overrides: tuple[str, ...] = (),
        faults: tuple[str, ...] = (),
        start_timeout: float = START_TIMEOUT,
        credentials_dir: Path | None = None,
        zenoh_config: Path | None = None,
    ) -> None:
        self.listen = listen  # endpoint for the supervisor's router; default a free localhost port
        self.connect = connect  # join an existing router instead of being one
        self.remote = remote  # vehicles started by hand elsewhere: waited for, not spawned
        self.overrides = overrides  # --set KEY=VALUE, passed on to every child
        self.faults = faults  # --fault SPEC, passed on to every child
        self.start_timeout = start_timeout  # s for every process to come alive
        self.credentials_dir = credentials_dir  # where the --remote vehicles' credential files are written
        self.zenoh_config = zenoh_config  # the site's Zenoh config file, under cpf's settings, every process's
        self.per_process: int | None = None  # vehicles per vehicle process (None: supervisor.engine.hosting's default)
        self.fork = True  # children forked from a fork server where the platform allows (supervisor.cli.fork_server)


@dataclass(frozen=True, slots=True)
class Launch:
    """What every child of one run is started with."""

    path: Path  # the scenario file
    connect: str  # the endpoint children connect to
    bus: BusOptions
    seed: int
    private_dir: Path  # the run's own (0700): where each vehicle process's starts are handed over

    def argv(self, command: str, *extra: str) -> list[str]:
        sets = [arg for override in self.bus.overrides for arg in ("--set", override)]
        faults = [arg for fault in self.bus.faults for arg in ("--fault", fault)]
        # -P: the working directory is not put on the child's path, so it runs the supervisor's code, not a package
        # of the same name that the user's directory happens to hold
        base = [sys.executable, "-P", "-m", "supervisor.cli", command, str(self.path), "--connect", self.connect]
        site = ["--zenoh-config", str(self.bus.zenoh_config)] if self.bus.zenoh_config is not None else []
        seed = ["--seed", str(self.seed)] if command == "vehicle" else []  # the comms broker's comes in extra
        return [
            *base,
            *sets,
            *faults,
            *site,
            *seed,
            *extra,
        ]  # credentials: in the environment (supervisor.engine.bus_access)

    def handover(self, name: str, start: tuple[VehicleStart, ...] | BrokerStart) -> list[str]:
        """The options that hand the process `name` what it serves (a vehicle process its starts, the broker its
        start): written to a file of the run's private directory, one per process start (a restart's replaces the
        last)."""
        path = self.private_dir / f"{file_stem(name)}.start"
        path.unlink(missing_ok=True)
        write_private(path, start)
        return ["--plan", str(path)]


def reachable(endpoint: str) -> str:
    """How another host names an endpoint the supervisor listens on (an unspecified address: any of this host's)."""
    return endpoint.replace("0.0.0.0", "<this host>").replace("[::]", "<this host>")


def local(endpoint: str) -> str:
    """How processes on this machine reach an endpoint the supervisor listens on."""
    return endpoint.replace("0.0.0.0", "127.0.0.1").replace("[::]", "[::1]")

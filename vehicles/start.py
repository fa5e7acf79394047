"""What a vehicle process serves a vehicle with, whole, and the private file the supervisor hands it over in.

A process the supervisor starts does not load the scenario: validating it (pydantic) and building the vehicles costs
a fresh process ~15 MB and ~0.1 s, which the supervisor has already paid. The supervisor writes each process's
VehicleStarts to a file of its run's private temporary directory instead (supervisor.engine.launch), and the process
reads them back here. A vehicle started by hand elsewhere (`cpf vehicle --remote ...`) still loads the scenario file.

The encoding is pickle, for two reasons. It carries our own dataclasses whole, with whatever fields they grow (a new
path kind, vehicle parameters, transmission policy) and numpy state arrays bit for bit, with no schema to keep beside
them. And the file cannot be another user's: it is created 0600 in a 0700 directory of the user running both
processes, and read_starts refuses one that is not the user's own or that others could write, so whoever could make
it unpickle something could already run code as that user.
"""

from __future__ import annotations

import os
import pickle
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from comms.fields import Message
from vehicles.agent import VehicleConfig
from vehicles.runtime import NodeState, Radio


@dataclass(frozen=True, slots=True)
class VehicleStart:
    """Everything vehicles.node.run_vehicle serves one vehicle with, but the bus (endpoint, credential)."""

    cfg: VehicleConfig
    initial: NodeState  # at start_step: the scenario's initial state, or a restarted vehicle's last recorded one
    radio: Radio
    neighbours: tuple[int, ...]  # the scenario's graph, until a tick says otherwise
    dt: float
    hello: Message  # its answer to which scenario it runs (comms.messages.Hello): the supervisor's own digests
    start_step: int = 0


def write_starts(path: Path, starts: Sequence[VehicleStart]) -> None:
    """The starts of one process, to a new file only its owner can read or write."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as out:
        pickle.dump(tuple(starts), out, protocol=pickle.HIGHEST_PROTOCOL)


def read_starts(path: Path) -> tuple[VehicleStart, ...]:
    """The starts the supervisor wrote; ValueError '<file>: <problem>' for a file that is not a private file of
    this user's holding them."""
    try:
        with path.open("rb") as given:
            info = os.fstat(given.fileno())
            if info.st_uid != os.getuid() or info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
                raise ValueError(f"{path}: not a private file of this user's (mode {stat.filemode(info.st_mode)})")
            starts = pickle.load(given)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read it ({exc.strerror})") from None
    except (pickle.UnpicklingError, EOFError, AttributeError, ImportError) as exc:
        raise ValueError(f"{path}: not vehicle starts written by cpf run ({exc})") from None
    if not isinstance(starts, tuple) or not all(isinstance(s, VehicleStart) for s in starts):
        raise ValueError(f"{path}: not vehicle starts written by cpf run (a {type(starts).__name__})")
    return starts

"""The private file a supervisor hands a process it starts over in: what the process serves, whole.

A process the supervisor starts does not load the scenario: validating it (pydantic) and building what it serves
costs a fresh process ~15 MB and ~0.1 s, which the supervisor has already paid. The supervisor writes the process's
start to a file of its run's private temporary directory instead (supervisor.engine.launch), and the process reads
it back here (vehicles.start, comms.broker.broker's BrokerStart). A process started by hand elsewhere still loads the
scenario file.

The encoding is pickle, for two reasons. It carries our own dataclasses whole, with whatever fields they grow (a new
path kind, vehicle parameters, a channel model) and numpy state arrays and random generators bit for bit, with no
schema to keep beside them. And the file cannot be another user's: it is created 0600 in a 0700 directory of the
user running both processes, and read_private refuses one that is not the user's own or that others could write, so
whoever could make it unpickle something could already run code as that user.
"""

from __future__ import annotations

import os
import pickle
import stat
from pathlib import Path
from typing import TypeVar

T = TypeVar("T")


def write_private(path: Path, start: object) -> None:
    """start, to a new file only its owner can read or write."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as out:
        pickle.dump(start, out, protocol=pickle.HIGHEST_PROTOCOL)


def read_private(path: Path, kind: type[T], what: str) -> T:
    """What write_private wrote, if it is a kind; ValueError '<file>: <problem>' for a file that is not a private
    file of this user's holding one (what: how the problem names it, e.g. 'vehicle starts written by cpf run')."""
    try:
        with path.open("rb") as given:
            info = os.fstat(given.fileno())
            if info.st_uid != os.getuid() or info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
                raise ValueError(f"{path}: not a private file of this user's (mode {stat.filemode(info.st_mode)})")
            start = pickle.load(given)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read it ({exc.strerror})") from None
    except (AttributeError, ImportError) as exc:  # a class it holds (an extension's) does not import here
        raise ValueError(
            f"{path}: {what} holding a class this process cannot import ({exc}): an extension's module must be on "
            "the PYTHONPATH of the processes a run starts"
        ) from None
    except (pickle.UnpicklingError, EOFError, IndexError) as exc:
        raise ValueError(f"{path}: not {what} ({exc})") from None
    if not isinstance(start, kind):
        raise ValueError(f"{path}: not {what} (a {type(start).__name__})")
    _consumed(path)
    return start


def _consumed(path: Path) -> None:
    """A hand-over the supervisor gave a process it launched is gone once read (a restart gets a new one), and its
    directory, empty once every process has started, is removed by whichever process sees the supervisor gone first
    (comms.bus.lifeline): a supervisor killed by SIGKILL left it, with a start file per process, in /tmp (a new
    user). A --plan file a user hands a process started by hand is the user's: left."""
    from comms.bus.lifeline import LIFELINE_ENV, remove_when_cut

    if LIFELINE_ENV in os.environ:  # launched by the supervisor (lifeline.watch takes the mark only later, in serve)
        path.unlink(missing_ok=True)
        remove_when_cut(path.parent)

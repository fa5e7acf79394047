"""A spawned child's lifeline to its supervisor: the child ends within about a second of the supervisor's end,
however that end comes (SIGKILL included) and whenever (start-up included).

The supervisor's Zenoh liveliness token tells a child the supervisor is gone only once the child has joined the bus
and seen the token; a supervisor killed during start-up left children waiting 30 s for a router that never came
back. Two mechanisms, both set up before the child runs any code of its own:

- A pipe (POSIX): the child's stdin is the read end of a pipe whose write end only the supervisor holds. The kernel
  closes it however the supervisor ends, and the child reads EOF: `watch`, from the first line of the child's
  `serve`, waits for it in a thread; then the child's loop stops (token undeclared, session closed) and, should it
  not manage within GRACE (e.g. still connecting to the dead router), the thread ends the process.
- Linux, for the start-up before `watch` runs (interpreter, imports: seconds on a loaded machine): this file, run as
  a script, launches the child's command line after asking the kernel for SIGKILL when its parent dies
  (prctl(PR_SET_PDEATHSIG), kept over exec), and exits if the parent already died (reparented: the race before the
  prctl). `watch` withdraws the signal once its thread waits on the pipe, so that from then on the child stops
  cleanly. The kernel's "parent" is the thread that forked: the supervisor asks for the signal only when it spawns
  from its main thread (which lives as long as the process).

The launcher marks the child with LIFELINE_ENV; a process started by hand (no supervisor parent, stdin whatever the
shell gave) has no mark and watches nothing: the supervisor's liveliness token remains its way to notice.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import signal
import sys
import threading
import time

LIFELINE_ENV = "CPF_LIFELINE"  # set (to the fd watched) in a child spawned through the launcher
GRACE = 1.0  # s the child has to stop by itself after the supervisor is gone, before it is ended at once
ORPHANED = 3  # exit code of a child ended by its lifeline (nobody reads it: the supervisor is gone)
_PR_SET_PDEATHSIG = 1  # linux/prctl.h

log = logging.getLogger(f"cpf.{__name__}")  # under cpf: silenced with it (docs/api.md)
_LEFT: list[str] = []  # directories of the supervisor's this process removes, if empty, once it is gone


def remove_when_cut(directory: os.PathLike[str] | str) -> None:
    """directory (the run's private one, emptied as its processes start) removed if empty when the lifeline is cut:
    the supervisor, gone by SIGKILL, could not. Only once it is gone: it may still hand a restart over there."""
    if os.fspath(directory) not in _LEFT:  # a host reads one hand-over; a test process may read many
        _LEFT.append(os.fspath(directory))


def launcher(argv: list[str], parent_death_signal: bool) -> list[str]:
    """The command line that runs argv with the lifeline (stdin must be the pipe's read end). With
    parent_death_signal, on Linux, the child is also killed by the kernel when the calling thread ends."""
    parent = str(os.getpid()) if parent_death_signal else "0"
    # -I -S: nothing but the standard library, so that the launcher's own start-up is a few tens of ms
    return [sys.executable, "-I", "-S", os.path.abspath(__file__), parent, *argv]


def set_parent_death_signal(sig: int) -> bool:
    """prctl(PR_SET_PDEATHSIG, sig) on Linux; False elsewhere or if the kernel refused."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(None, use_errno=True)
    return int(libc.prctl(_PR_SET_PDEATHSIG, sig, 0, 0, 0)) == 0


def _launch(parent: int, argv: list[str]) -> None:
    """The launcher's work: the parent-death signal (if asked for and available), then exec argv."""
    if parent and set_parent_death_signal(signal.SIGKILL) and os.getppid() != parent:
        os._exit(ORPHANED)  # the supervisor died before the prctl: the signal will never come
    os.environ[LIFELINE_ENV] = "0"
    os.execv(argv[0], argv)


class Lifeline:
    """The watch on the pipe: `cut` is set once the supervisor is gone."""

    def __init__(self, fd: int, name: str) -> None:
        self.cut = threading.Event()
        self._fd, self._name = fd, name
        threading.Thread(target=self._watch, name="lifeline", daemon=True).start()

    def _watch(self) -> None:
        while True:
            try:
                if not os.read(self._fd, 4096):
                    break  # EOF: every write end is closed, i.e. the supervisor is gone
            except InterruptedError:
                continue
            except OSError:
                return  # not a pipe after all: nothing to watch
        self.cut.set()
        log.warning("%s: the supervisor is gone (its lifeline closed), stopping", self._name)
        for directory in _LEFT:  # not empty (a process not yet started) or another's lifeline was first: left
            with contextlib.suppress(OSError):
                os.rmdir(directory)
        time.sleep(GRACE)  # the child's own loop stops it meanwhile, cleanly; if not, it ends here
        os._exit(ORPHANED)


def watch(name: str) -> Lifeline | None:
    """In a child launched by the supervisor: watch its lifeline, then withdraw the parent-death signal (the
    lifeline covers from now on, and lets the child stop cleanly). None in a process started by hand."""
    fd = os.environ.pop(LIFELINE_ENV, None)  # not inherited: a process this child starts is not launched by it
    if fd is None or not fd.isdigit():
        return None
    lifeline = Lifeline(int(fd), name)
    set_parent_death_signal(0)
    return lifeline


if __name__ == "__main__":
    _launch(int(sys.argv[1]), sys.argv[2:])

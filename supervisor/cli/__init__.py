"""The `cpf` command line. The only place that talks to the user: it turns errors into messages and exit codes,
prints results, progress lines and the warnings library code logs.

Exit codes: 0 success, 1 run-time failure, 2 bad input (scenario file or arguments), 130 interrupted.
parser: the arguments; run: `cpf run` and the processes it starts; commands: the other commands; terminal: exit
codes, progress lines and prompts.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
from collections.abc import Callable, Sequence

from supervisor import collector
from supervisor.cli import commands, run
from supervisor.cli.parser import _parser
from supervisor.cli.run import _option_errors
from supervisor.engine import interrupts
from supervisor.errors import EXIT_INPUT, EXIT_INTERRUPTED, EXIT_RUNTIME, CpfError, ScenarioError, shown

__all__ = ["EXIT_INPUT", "EXIT_INTERRUPTED", "EXIT_RUNTIME", "_option_errors", "_parser", "entry", "main"]

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "run": run.run,
    "vehicle": run.vehicle,
    "comms": run.comms,
    "report": commands.report,
    "info": commands.info,
    "recover": commands.recover,
    "export": commands.export,
    "sweep": commands.sweep,
    "resim": commands.resim,
    "replay": commands.replay,
    "schema": commands.schema,
    "validate": commands.validate,
    "stability": commands.stability,
    "presets": commands.presets,
    "plugins": commands.plugins,
    "per": commands.per,
}


# Every matrix of ours is 3x3 to 6x6 and every process does its own (a run is many processes on a small machine):
# OpenBLAS's worker threads, one per core and started with numpy, can only spin. One thread halves a vehicle
# process's start-up CPU (0.23 -> 0.13 s measured) and takes ~0.4 s of CPU off a paper run. Set before any command
# imports numpy; the processes a run starts inherit it; a value the user set is kept.
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "1")


def main(argv: Sequence[str] | None = None) -> int:
    os.environ.setdefault(*BLAS_THREADS)
    collector.pace()  # the process is ours to its end (forked ones too: they come here)
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format=f"cpf {args.command}: %(message)s")
    interrupts.reset()
    signal.signal(signal.SIGTERM, interrupts.handle)  # SIGTERM cleans up like Ctrl-C: children stopped, log closed
    signal.signal(signal.SIGINT, interrupts.handle)
    try:
        return COMMANDS[args.command](args)
    except BrokenPipeError:  # output piped into e.g. head, which stopped reading: what it wanted, no error
        return _reader_gone()
    except ScenarioError as exc:
        for line in shown(exc.errors):  # every error found, one line each, up to SHOWN_ERRORS and a count
            print(f"cpf: error: {line}", file=sys.stderr)
        return EXIT_INPUT
    except (CpfError, ConnectionError, FloatingPointError) as exc:  # FloatingPointError: a vehicle diverged
        print(f"cpf: error: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    except OSError as exc:  # an output that cannot be written now (a full disk, /dev/full): the file and why
        print(f"cpf: error: {_os_error(exc)}", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt:
        print("cpf: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _os_error(exc: OSError) -> str:
    """'<file>: <reason>' of an OSError (the reason alone if it names no file)."""
    why = exc.strerror or str(exc)
    return f"{exc.filename}: {why}" if exc.filename is not None else why


def _reader_gone() -> int:
    """The reader of our output left (SIGPIPE, which Python turns into BrokenPipeError): exit 0 without a word, as
    a command in a pipe does; what is left to write goes to /dev/null, so the interpreter's last flush cannot fail."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0


def entry() -> None:
    """Console-script entry point."""
    try:
        code = main()
    except KeyboardInterrupt:  # before main's handlers were in place, or between them: one line all the same
        print("cpf: interrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    # Said and done, whatever the code: a Ctrl-C or SIGTERM now must not end the exit by the signal. Python's exit
    # puts SIG_DFL back for every signal with a handler of ours (not for one ignored), and its exit waits for the
    # bus's threads: a second press 50 ms after an interrupt killed the process (-2) in 12 of 16 tries (issue 29);
    # one just after a run's summary ended it by the signal or in a KeyboardInterrupt traceback (a new user).
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)
    try:
        sys.stdout.flush()  # here, not at the interpreter's exit: a reader gone is then exit 0, not 120
    except BrokenPipeError:
        code = _reader_gone() or code
    sys.exit(code)

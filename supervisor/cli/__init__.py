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

from supervisor.cli import commands, run
from supervisor.cli.parser import _parser
from supervisor.cli.run import _option_errors
from supervisor.cli.terminal import EXIT_INPUT, EXIT_INTERRUPTED, EXIT_RUNTIME
from supervisor.engine import interrupts
from supervisor.errors import CpfError, ScenarioError, shown

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
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format=f"cpf {args.command}: %(message)s")
    signal.signal(signal.SIGTERM, interrupts.handle)  # SIGTERM cleans up like Ctrl-C: children stopped, log closed
    signal.signal(signal.SIGINT, interrupts.handle)
    try:
        return COMMANDS[args.command](args)
    except BrokenPipeError:  # output piped into e.g. head, which stopped reading: not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_RUNTIME
    except ScenarioError as exc:
        for line in shown(exc.errors):  # every error found, one line each, up to SHOWN_ERRORS and a count
            print(f"cpf: error: {line}", file=sys.stderr)
        return EXIT_INPUT
    except (CpfError, ConnectionError, FloatingPointError) as exc:  # FloatingPointError: a vehicle diverged
        print(f"cpf: error: {exc}", file=sys.stderr)
        return EXIT_RUNTIME
    except KeyboardInterrupt:
        print("cpf: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def entry() -> None:
    """Console-script entry point."""
    sys.exit(main())

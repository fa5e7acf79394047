"""The `cpf` console script's entry point, light on purpose: a Ctrl-C (or SIGTERM) while Python imports the command
line (0.5-1 s on a loaded 2-core machine) is one line and exit 130 like one at any later moment, not a
KeyboardInterrupt traceback and death by the signal (-2: a double press 0.3 s after start under load). Only the
console script sets these handlers: `import supervisor.cli` from a notebook or a test must leave its signals alone.
"""

from __future__ import annotations

import signal
import sys

from supervisor.errors import EXIT_INTERRUPTED


def entry() -> None:
    pressed: list[int] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, _frame: pressed.append(signum))
    from supervisor.cli import entry as command_line

    try:
        signal.signal(signal.SIGINT, signal.default_int_handler)  # main puts its own in place; until then, Python's
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        if pressed:  # during the imports (looked at once the handlers are back: none falls between)
            raise KeyboardInterrupt
    except KeyboardInterrupt:  # nothing was started: nothing to stop
        print("cpf: interrupted", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    command_line()

"""One error hierarchy. Library code raises these; only the CLI turns them into messages and exit codes."""

# cpf's exit codes: success 0, a run-time failure, bad input (scenario file or arguments), interrupted. Here, the
# lowest layer, so that the console script's entry (supervisor.console) has them without importing the command line.
EXIT_RUNTIME, EXIT_INPUT, EXIT_INTERRUPTED = 1, 2, 130


class CpfError(Exception):
    """Root of every error cpf-cosim raises on purpose."""


SHOWN_ERRORS = 20  # errors told one line each; the others counted (a fleet of 10,000 gave 29,234 lines)


def shown(errors: list[str]) -> list[str]:
    """The first SHOWN_ERRORS errors, and a line counting the rest if any."""
    rest = len(errors) - SHOWN_ERRORS
    return errors if rest <= 0 else [*errors[:SHOWN_ERRORS], f"... and {rest} more ({len(errors)} errors in all)"]


class ScenarioError(CpfError):
    """The scenario (file or command-line override) is invalid: set-up never started. Exit code 2.

    errors: every error found, one line each (the message is the first SHOWN_ERRORS of these lines and a count of the
    others; the first is the usual one-line error).
    """

    def __init__(self, message: str, errors: list[str] | None = None) -> None:
        super().__init__("\n".join(shown(errors)) if errors else message)
        self.errors: list[str] = list(errors) if errors else str(message).splitlines()


class SimulationError(CpfError):
    """Something failed while a run was under way. Exit code 1."""


class LogWriteError(SimulationError):
    """The log could not be written (the disk full, ...): exit code 1, one line; what was written is recoverable."""


class LogError(ScenarioError):
    """A log that cannot be read: missing, not an MCAP, cut short or damaged (exit code 2)."""


class RecoveryError(CpfError, ValueError):
    """`cpf recover`: the source cannot be recovered at all: not an MCAP, or the destination would overwrite it."""


class CorruptRecord(Exception):
    """`cpf recover`, internal: a record that is not what its prefix announces; the scan stops before it. Not a
    CpfError: recovery catches it, it never reaches the user."""


class TooManyDescriptors(OSError):
    """A child whose descriptors one message to the fork server cannot pass (a host of > 250 vehicles: each its
    credential): it is spawned instead, and the fork server goes on serving (supervisor.forked)."""

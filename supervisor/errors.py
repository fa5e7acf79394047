"""One error hierarchy. Library code raises these; only the CLI turns them into messages and exit codes."""


class CpfError(Exception):
    """Root of every error cpf-cosim raises on purpose."""


class ScenarioError(CpfError):
    """The scenario (file or command-line override) is invalid: set-up never started. Exit code 2.

    errors: every error found, one line each (the message is these lines; the first is the usual one-line error).
    """

    def __init__(self, message: str, errors: list[str] | None = None) -> None:
        super().__init__(message)
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

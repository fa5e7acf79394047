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

"""One error hierarchy. Library code raises these; only the CLI turns them into messages and exit codes."""


class CpfError(Exception):
    """Root of every error cpf-cosim raises on purpose."""


class ScenarioError(CpfError):
    """The scenario (file or command-line override) is invalid: set-up never started. Exit code 2."""


class SimulationError(CpfError):
    """Something failed while a run was under way. Exit code 1."""

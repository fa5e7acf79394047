"""`python -m supervisor.cli`: the `cpf` command."""

from supervisor.cli import entry

entry()

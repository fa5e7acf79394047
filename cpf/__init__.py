"""cpf-cosim from Python: run a scenario, load a run's log, sweep parameters, and get pandas tables back.

    import cpf

    run = cpf.run("configs/paper.toml", set={"comms.loss": 0.2}, seed=3)
    run.states          # one row per vehicle and step: t, k, vehicle, gamma, gamma_dot, position_x, ...
    run.summary         # the numbers of metrics.json (`cpf report`) and `cpf run`'s summary
    run.figures()       # the figures of `cpf report`, as matplotlib Figures
    cpf.load("runs/paper/run.mcap").link_events  # the log `make run` writes
    cpf.sweep("configs/paper.toml", params={"comms.loss": [0, 0.2]}, seeds=2)

`cpf.run` goes through `cpf run`'s own code (supervisor.cli.run.execute); errors are raised, never printed:
ScenarioError for bad input (the message `cpf run` prints after 'cpf: error: '), SimulationError for a run that
failed, LogError for a log that cannot be read. docs/api.md is the reference.
"""

from cpf.api import load, run, sweep
from cpf.runs import Run
from supervisor.errors import CpfError, LogError, ScenarioError, SimulationError

__all__ = ["CpfError", "LogError", "Run", "ScenarioError", "SimulationError", "load", "run", "sweep"]

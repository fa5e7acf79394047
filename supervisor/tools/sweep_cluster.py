"""`cpf sweep --cluster ADDRESS`: the sweep's runs on a Dask distributed cluster, through its concurrent.futures
executor (distributed.Client.get_executor), so supervisor.tools.sweep drives a cluster as it drives local processes.

Each run goes to a worker as a call of supervisor.tools.sweep_runs.run_one with the scenario file's bytes (one run a
call: a cluster's workers may be many, and come and go), and comes back as its row, which the client writes to
DIR/runs/<id>.json: the workers need cpf-cosim installed (the same version) but no filesystem shared with the
client. Dask places the runs, runs one again elsewhere when its worker dies
(distributed.scheduler.allowed-failures times, then reports it: KilledWorker), and the client watches that the
cluster keeps a worker at all. `distributed` is imported here only, when a cluster sweep starts: `cpf` and the
vehicle processes stay light.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Iterator
from concurrent.futures import Executor
from typing import TYPE_CHECKING

from supervisor.errors import ScenarioError, SimulationError

if TYPE_CHECKING:
    from distributed import Client

CLUSTER_TIMEOUT = 30.0  # s: distributed's own connect timeout; also how long the cluster may have no worker


class WorkerWatch:
    """A connected Dask cluster: its executor, and a watch on its workers (watch() between completions)."""

    def __init__(self, client: Client, address: str, timeout: float) -> None:
        self.client = client
        self.address = address
        self.timeout = timeout
        self._workerless_since: float | None = None

    def watch(self) -> None:
        """SimulationError once the cluster has had no worker for timeout s: its runs would wait for ever."""
        try:
            workers = self.client.nthreads()
        except OSError as exc:
            raise SimulationError(f"sweep: lost the Dask scheduler at {self.address} ({exc})") from None
        now = time.monotonic()
        if workers:
            self._workerless_since = None
        elif self._workerless_since is None:
            self._workerless_since = now
        elif now - self._workerless_since >= self.timeout:
            raise SimulationError(
                f"sweep: the Dask cluster at {self.address} has had no worker for {self.timeout:g} s "
                "(start some with `dask worker ADDRESS`; the runs done are kept: run the sweep again to resume)"
            )


@contextlib.contextmanager
def cluster_executor(address: str, timeout: float = CLUSTER_TIMEOUT) -> Iterator[tuple[Executor, WorkerWatch]]:
    """The executor of the Dask scheduler at address and its watch; ScenarioError (nothing started) if the scheduler
    cannot be reached within timeout s. On the way out the client cancels whatever it has not collected."""
    reach(address, timeout)
    from distributed import Client

    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, ValueError) as exc:  # reached a moment ago: gone since, or something that is not a scheduler
        raise ScenarioError(f"--cluster: no Dask scheduler answers there ({exc}), got {address}") from None
    with client, client.get_executor(pure=False) as executor:
        yield executor, WorkerWatch(client, address, timeout)


def reach(address: str, timeout: float) -> None:
    """ScenarioError unless a Dask comm to address opens within timeout s. Probed with distributed's comm layer, not
    a Client: a Client that failed to connect still tries to close at exit, with a traceback after another timeout."""
    from distributed.comm import connect
    from distributed.security import Security

    async def probe() -> None:
        comm = await connect(address, timeout=timeout, **Security().get_connection_args("client"))
        await comm.close()

    try:
        asyncio.run(probe())
    except ValueError as exc:
        raise ScenarioError(f"--cluster: not a Dask scheduler address ({exc}), got {address}") from None
    except OSError as exc:
        raise ScenarioError(f"--cluster: cannot reach a Dask scheduler ({exc}), got {address}") from None

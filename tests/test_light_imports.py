"""Every process of a run starts as `python -m supervisor.cli`: what that imports, each of a fleet's vehicle
processes pays in start-up time and memory (issue 15: ready within 0.5 s, <= 60 MB). The command line's own modules
import the heavy libraries of other commands (figures, logs, progress bars) only where those commands run."""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = ("matplotlib", "scipy", "mcap", "tqdm", "zstandard", "cryptography", "jsonschema", "dask", "distributed",
         "foxglove", "websockets")  # fmt: skip


def imported_by(code: str) -> set[str]:
    probe = f"import sys, json\n{code}\nprint(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}})))"
    done = subprocess.run([sys.executable, "-P", "-c", probe], capture_output=True, text=True, check=True)
    return set(json.loads(done.stdout))


def test_the_command_line_imports_no_heavy_library() -> None:
    assert imported_by("import supervisor.cli").isdisjoint(HEAVY)


def test_a_vehicle_process_imports_only_what_it_steps_with() -> None:
    code = "import supervisor.cli.run, supervisor.config.fleet, supervisor.config.scenario, vehicles.node"
    assert imported_by(code).isdisjoint(HEAVY)


def test_a_run_over_tcp_imports_no_tls_library() -> None:
    """TLS certificates are made (with cryptography) only for a tls/ endpoint: every other run's supervisor starts
    ~17 ms sooner without it."""
    assert "cryptography" not in imported_by("import supervisor.engine.cosim, supervisor.engine.bus_access")

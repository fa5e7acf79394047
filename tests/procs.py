"""Helpers for tests that run `cpf` as a user would and check what it leaves behind."""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType

CPF = str(Path(sys.executable).parent / "cpf")
ROOT = Path(__file__).resolve().parent.parent


def script(name: str) -> ModuleType:
    """scripts/<name>.py as a module (scripts/ is not a package): for testing a script's own functions."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def cpf(
    *args: str, cwd: Path, timeout: float = 300, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """cpf as a user runs it; env: variables set on top of this process's environment."""
    full = None if env is None else {**os.environ, **env}
    return subprocess.run([CPF, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=full)


def start_cpf(args: Sequence[str], cwd: Path) -> subprocess.Popen[str]:
    """cpf in the background, stderr readable line by line (the progress lines). Its temporary files go under cwd:
    a cpf the test SIGKILLs cannot remove them itself."""
    env = {**os.environ, "TMPDIR": str(cwd)}
    return subprocess.Popen([CPF, *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def processes_with(marker: str) -> list[tuple[int, str]]:
    """(pid, command line) of every live process whose command line mentions marker, this one excepted."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue  # gone meanwhile
        if marker in cmdline:
            found.append((int(entry.name), cmdline))
    return found


def watching_lifeline(pid: int) -> bool:
    """A thread of the process waits in the kernel's pipe read (the lifeline's: nothing else of a child does)."""
    try:
        return any("pipe" in (task / "wchan").read_text() for task in Path(f"/proc/{pid}/task").iterdir())
    except OSError:
        return False


def threads(pid: int) -> int:
    """How many threads the process has (0 once it is gone)."""
    try:
        return len(os.listdir(f"/proc/{pid}/task"))
    except OSError:
        return 0


def wait_until(condition: Callable[[], bool], timeout: float = 60.0) -> bool:
    """Poll until condition holds; False if it still does not at the deadline."""
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() >= end:
            return False
        time.sleep(0.005)
    return True


def wait_for_progress(process: subprocess.Popen[str], simulated: float = 0.0) -> str:
    """Read cpf's stderr until a progress line shows at least `simulated` seconds done (or cpf ends)."""
    assert process.stderr is not None
    for line in process.stderr:
        if line.startswith("t = ") and float(line.split()[2]) >= simulated:
            return line
    raise AssertionError(f"cpf ended (code {process.wait()}) before any progress line")


def wait_for_no_processes(marker: str, timeout: float = 20.0) -> list[tuple[int, str]]:
    """Poll until no process mentions marker (the children of a killed supervisor stop by themselves, when their
    lifeline closes or its liveliness token disappears; nothing else tells the test when). Returns what is left at
    the deadline."""
    end = time.monotonic() + timeout
    while (left := processes_with(marker)) and time.monotonic() < end:
        time.sleep(0.1)
    return left


def kill_vehicle_process(marker: str, vehicle: int) -> None:
    """SIGKILL the one process of `vehicle` in the run whose command lines mention marker."""
    victims = [pid for pid, cmd in processes_with(marker) if " vehicle " in cmd and f"--id {vehicle}" in cmd]
    assert len(victims) == 1, victims
    os.kill(victims[0], signal.SIGKILL)


def wait_for_file(path: Path, timeout: float = 60.0) -> None:
    """Poll until a file another process writes exists (cpf run's credential files: nothing else says when)."""
    end = time.monotonic() + timeout
    while not path.exists() and time.monotonic() < end:
        time.sleep(0.05)
    assert path.exists(), f"{path} was not written within {timeout:g} s"

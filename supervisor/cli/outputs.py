"""Output paths checked before a run starts: each a file that can be written, none a directory, none under a file,
none in use by another run, none the same as another output or the scenario itself."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


def _writable_file(option: str, path: Path, regular: bool = True) -> list[str]:
    """What keeps path from being written as a file, '<option>: <problem>, got <path>' each. regular: only a regular
    file (a log, locked, truncated, written beside and renamed over: a device or FIFO given as --out hung, failed in a
    traceback, or was replaced by a file, /dev/null included; found by a new user); else a stream will do (--metrics
    /dev/stdout)."""
    if path.is_dir():
        return [f"{option}: is a directory, not a file, got {path}"]
    if regular and path.exists() and not path.is_file():
        return [f"{option}: not a regular file (a device, FIFO or socket), got {path}"]
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        return [f"{option}: {ancestor} is a file, not a directory, got {path}"]
    if not os.access(ancestor, os.W_OK | os.X_OK) or (path.exists() and not os.access(path, os.W_OK)):
        return [f"{option}: not writable, got {path}"]
    problem = _cannot_open(path) if path.exists() else _cannot_create_in(ancestor)
    return [] if problem is None else [f"{option}: not writable ({problem}), got {path}"]


def _cannot_open(path: Path) -> str | None:
    """Why an existing file cannot be opened for writing (None: it can): appending nothing leaves it as it was."""
    try:
        with path.open("ab"):
            return None
    except OSError as exc:
        return exc.strerror or str(exc)


def _cannot_create_in(directory: Path) -> str | None:
    """Why nothing can be made in directory (None: something can), tried: os.access says yes to root on file
    systems that refuse (sysfs, procfs) and on read-only mounts."""
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".cpf-probe-", dir=directory))
        return None
    except OSError as exc:
        return exc.strerror or str(exc)


def checked_file(option: str, path: Path, source: Path | None = None) -> Path:
    """path, if it can be written as a file (before any work) and is not source (the log the command reads: written
    over, it would be lost); ScenarioError '<option>: <problem>, got <path>'."""
    from supervisor.errors import ScenarioError

    problems = _writable_file(option, path)
    if source is not None and path.resolve() == source.resolve():
        problems.append(f"{option}: the same file as the log it reads (it would be written over), got {path}")
    if problems:
        raise ScenarioError(problems[0])
    return path


def output_errors(scenario: Path, outputs: dict[str, Path | None]) -> list[str]:
    """Every problem of the outputs a command will write (option -> path; None: not asked for)."""
    from supervisor.record.recorder import in_use

    given = {option: path for option, path in outputs.items() if path is not None}
    errors = [line for option, path in given.items() for line in _writable_file(option, path, option == "--out")]
    seen: dict[Path, str] = {scenario.resolve(): "the scenario file"}
    for option, path in given.items():
        where = path.resolve()
        if where in seen:
            errors.append(f"{option}: the same file as {seen[where]}, got {path}")
        seen.setdefault(where, option)
    log = given.get("--out")
    if log is not None and log.is_file() and in_use(log):
        errors.append(f"--out: in use: another run is writing this log, got {log}")
    return errors


def checked_directory(option: str, path: Path) -> Path:
    """path, if it is a directory that can be written or can be made (before any work, without making it: a command
    that fails later leaves nothing); ScenarioError '<option>: <problem>, got <path>' otherwise."""
    from supervisor.errors import ScenarioError

    if path.exists() and not path.is_dir():
        raise ScenarioError(f"{option}: not a directory, got {path}")
    ancestor = path
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ScenarioError(f"{option}: {ancestor} is a file, not a directory, got {path}")
    problem = _cannot_create_in(ancestor)
    if problem is not None:
        raise ScenarioError(f"{option}: cannot make the directory ({problem}), got {path}")
    return path


def made_directory(option: str, path: Path) -> None:
    """The directory path, made if missing (a command's output directory, before any work); ScenarioError
    '<option>: <problem>, got <path>' if it is a file, under one, or cannot be made or written."""
    from supervisor.errors import ScenarioError

    if path.exists() and not path.is_dir():
        raise ScenarioError(f"{option}: not a directory, got {path}")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise ScenarioError(f"{option}: a file is in the way, got {path}") from None
    except OSError as exc:
        raise ScenarioError(f"{option}: cannot make the directory ({exc.strerror or exc}), got {path}") from None
    problem = _cannot_create_in(path)
    if problem is not None:
        raise ScenarioError(f"{option}: not writable ({problem}), got {path}")

"""What a log is drawn from, when it is not a run as it ran: a log rebuilt by `cpf recover` (how much of its source
was kept and lost) or written by `cpf resim` (from which log, with which settings changed). Each says so in an MCAP
metadata record of its own (not a message: the run's records and their schemas stay as they are), which
`cpf report` shows first and writes into metrics.json (`drawn_from`)."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader

RECOVERED = "cpf.recovered"  # {"source": its path, "kept": what recover kept and lost}
RESIM = "cpf.resim"  # {"source": the log re-simulated, "set": the overrides, space-separated}


def drawn_from(path: Path) -> str | None:
    """One line saying what the log is drawn from, None for a run's own log (or one unreadable here: the log's
    readers say what is wrong with it)."""
    try:
        with path.open("rb") as stream:
            notes = {record.name: record.metadata for record in make_reader(stream).iter_metadata()}
    except Exception:  # a damaged log: its readers refuse it with the reason (supervisor.record.logfile)
        return None
    if RECOVERED in notes:
        note = notes[RECOVERED]
        return f"drawn from a log recovered from {note.get('source', '?')}: {note.get('kept', '?')}"
    if RESIM in notes:
        note = notes[RESIM]
        changed = note.get("set") or "nothing changed"
        return f"drawn from a re-simulation of {note.get('source', '?')} ({changed}): states only, no channel records"
    return None

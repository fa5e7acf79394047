"""A stop asked for by a signal is kept: a run whose KeyboardInterrupt was swallowed still ends at its next step."""

from __future__ import annotations

import io

import pytest

from supervisor.engine import progress


def test_a_kept_stop_request_ends_the_next_update(monkeypatch):
    monkeypatch.setattr(progress, "_stop_requested", False)
    line = progress.Progress(10.0, stream=io.StringIO())
    line.update(1.0)  # nothing asked yet
    progress.request_stop()
    with pytest.raises(KeyboardInterrupt):
        line.update(2.0)
    with pytest.raises(KeyboardInterrupt):  # and again: the request stands until the process ends
        line.update(3.0)
    monkeypatch.setattr(progress, "_stop_requested", False)


def test_the_cli_handler_keeps_the_request(monkeypatch):
    from supervisor.cli import _interrupt

    monkeypatch.setattr(progress, "_stop_requested", False)
    with pytest.raises(KeyboardInterrupt):
        _interrupt(2, None)
    assert progress._stop_requested
    monkeypatch.setattr(progress, "_stop_requested", False)

"""The command line's progress lines and prompts (supervisor/cli/terminal.py): what the user sees, on any stream."""

from __future__ import annotations

import io

from supervisor.cli.terminal import ProgressLine, SweepBar, wait_to_start


def test_the_replay_progress_line_says_the_log_time_once_a_second_at_most():
    stream = io.StringIO()
    line = ProgressLine(stream)
    line(12.0)
    line(13.0)  # within the same second of wall time: not written
    line.close()
    assert stream.getvalue() == "replaying t =      12.0 s\n"


def test_the_replay_prompt_says_where_and_waits_for_the_delay_only():
    stream = io.StringIO()
    wait_to_start(0.0, stream)("Zenoh router listening on tcp/127.0.0.1:1")
    assert stream.getvalue() == "Zenoh router listening on tcp/127.0.0.1:1\n"


def test_the_sweep_bar_starts_at_the_runs_already_done(capsys):
    bar = SweepBar()
    bar(2, 5)
    bar(3, 5)
    bar(5, 5)
    bar.close()
    err = capsys.readouterr().err
    assert err.lstrip("\r").startswith("sweep:") and "2/5" in err and "5/5" in err and "1/5" not in err

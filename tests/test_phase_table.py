"""The run summary's phase table says what its path-error column leaves out: a run without faults has one row,
"whole run", whose max|p-pd| is over the time after the transient only (a researcher read 255 m as the whole run's
when the start error was 300 m).

Two vehicles over 100 s (1 s steps), path errors 300 m falling to 5 m at t = 50 s, the transient 50 s.
"""

from __future__ import annotations

import numpy as np

from supervisor.analysis.summary import Series, format_summary, summarize

T = np.arange(100, dtype=float)


def _table(faults: list[tuple[str, float, float]]) -> list[str]:
    error = np.stack([np.where(T < 50, 300.0, 5.0), np.full(T.size, 1.0)], axis=1)
    series = Series((1, 2), T, np.stack([T, T], axis=1), np.ones((T.size, 2)), error)
    return format_summary(summarize(series, 100.0, faults, 50.0, 1.2, 0.01)).splitlines()


def test_the_path_error_column_is_marked_as_after_the_transient():
    header, row, note = _table([])[:3]
    assert header.split()[5:8] == ["max|p-pd|", "[m]*", "mean"]
    assert row.split()[:3] == ["whole", "run", "0-100"] and row.split()[5] == "5.000"  # not 300: the transient
    assert note.startswith("* path-following error after the transient (from t = 50 s): max 5.000 m, tube 1.200 m")


def test_the_columns_stay_aligned_with_the_mark():
    header, row = _table([("blackout", 60.0, 70.0)])[:2]
    assert header.index("[m]*") + len("[m]*") == row.index("5.000") + len("5.000")

"""The supervisor's link books: lambda_2 of the delivered graph per window counts deliveries in (t - W, t]."""

from __future__ import annotations

import pytest

from comms.broker.stats import LinkStats
from comms.records.records import LinkEvent
from supervisor.engine.books import LinkBooks

IDS = (1, 2, 3)


def delivered(t: float, sender: int, receiver: int) -> LinkEvent:
    return LinkEvent(t, sender, receiver, 1, "delivered", delay=0.01)


def test_a_window_counts_deliveries_up_to_its_end_and_none_booked_ahead_of_it() -> None:
    books = LinkBooks(LinkStats(IDS, window=1.0))
    books.add([delivered(0.5, 1, 2), delivered(0.95, 2, 3)])
    books.add([delivered(1.05, 1, 3)])  # booked already, but it arrives after the window's end
    books.window(0.9)  # not a window boundary yet
    assert books.lambda2 == []
    books.window(1.0)
    assert books.lambda2 == [{"t": 1.0, "lambda2": pytest.approx(1.0)}]  # the path 1-2-3, not the triangle (3.0)
    books.window(2.0)  # (1, 2]: only 1-3 delivered, vehicle 2 cut off
    assert books.lambda2[-1] == {"t": 2.0, "lambda2": pytest.approx(0.0, abs=1e-12)}

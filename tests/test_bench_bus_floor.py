"""The bus-floor benchmark runs its bare message pattern to the end and leaves no process behind (no timing here)."""

from __future__ import annotations

from benchmarks.bench_bus_floor import measure_row
from tests.procs import processes_with


def test_the_bare_bus_pattern_completes_every_step_and_stops_its_children() -> None:
    for vehicles, per_process, lean in ((3, 1, False), (5, 2, False), (3, 1, True)):  # grouped: the last one short
        row = measure_row(vehicles, 20, per_process, lean)  # raises if a step does not complete within a minute
        assert row["ms_per_step"] > 0.0 and row["pattern"] == ("lean" if lean else "engine")
        assert processes_with("benchmarks.bench_bus_floor --child") == []

"""`Run`: one recorded run as pandas tables, its metrics and its figures, read from its log when first asked for."""

from __future__ import annotations

import shutil
import weakref
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

    from supervisor.analysis.rundata import RunData
    from supervisor.analysis.tx_books import BooksLog


class Run:
    """A run's log and what it holds, read from the log the first time any of it is asked for (every table and the
    report's data at once, in one pass of the one log reader), then kept.

    log: the MCAP file. states, transmissions, receptions, link_events, faults: the log's tables
    (supervisor.analysis.tables; docs/api.md gives their columns and units). summary: the run's metrics, the dict of
    metrics.json (`cpf report`); metrics: its phases as a table, one row per phase. figures(): `cpf report`'s figures.
    """

    def __init__(self, log: Path, temporary: Path | None = None) -> None:
        """temporary: a directory of the run's (its log, when it went nowhere else), deleted with the Run."""
        self.log = log
        if temporary is not None:
            weakref.finalize(self, shutil.rmtree, temporary, ignore_errors=True)

    def __repr__(self) -> str:
        return f"cpf.Run({str(self.log)!r})"

    @cached_property
    def _read(self) -> tuple[dict[str, pd.DataFrame], RunData, BooksLog]:
        """The tables, the report's RunData and its transmission books: one pass over the log gives them all."""
        from supervisor.analysis.tables import read_run
        from supervisor.analysis.tx_books import BooksLog

        books = BooksLog()
        tables, data = read_run(self.log, books)
        return tables, data, books

    @property
    def _tables(self) -> dict[str, pd.DataFrame]:
        return self._read[0]

    @property
    def states(self) -> pd.DataFrame:
        return self._tables["states"]

    @property
    def transmissions(self) -> pd.DataFrame:
        return self._tables["transmissions"]

    @property
    def receptions(self) -> pd.DataFrame:
        return self._tables["receptions"]

    @property
    def link_events(self) -> pd.DataFrame:
        return self._tables["link_events"]

    @property
    def faults(self) -> pd.DataFrame:
        return self._tables["faults"]

    @property
    def data(self) -> RunData:
        """The run as `cpf report` reads it (supervisor.analysis.rundata.load_run): arrays per vehicle and link."""
        return self._read[1]

    @cached_property
    def summary(self) -> dict[str, Any]:
        """Every metric of the run, the dict `cpf report` writes as metrics.json (one function gives both:
        supervisor.analysis.metrics.report_metrics)."""
        from supervisor.analysis.metrics import report_metrics

        return report_metrics(self.log, self.data, self._read[2])

    @cached_property
    def metrics(self) -> pd.DataFrame:
        """One row per phase (supervisor.analysis.tables.metrics_table): the numbers of `cpf run`'s summary."""
        from supervisor.analysis.tables import metrics_table

        return metrics_table(self.summary)

    def figures(self) -> dict[str, Figure]:
        """`cpf report`'s figures by name (its PNG's name without .png), built now: fig3_trajectories, ..."""
        from supervisor.analysis.report import figure_builders

        return {name: build(self.data) for name, build in figure_builders(self.data)}

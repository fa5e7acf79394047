"""`cpf export`: a recorded run's tables (supervisor.analysis.tables: the very DataFrames of the Python API's Run)
written one file per table, as CSV or Parquet. pyarrow, which Parquet needs, is asked for only by the Parquet export:
CSV needs pandas alone."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from supervisor.errors import ScenarioError

if TYPE_CHECKING:
    import pandas as pd

FORMATS = ("csv", "parquet")


def export_tables(log: Path, fmt: str, out_dir: Path) -> list[Path]:
    """Every table of the run in log (TABLES) to out_dir/<table>.<fmt>, which must exist; the paths written.
    ScenarioError for an unknown format or Parquet without pyarrow; LogError for a log that cannot be read."""
    from supervisor.analysis.tables import run_tables

    if fmt not in FORMATS:
        raise ScenarioError(f"--format: one of {', '.join(FORMATS)}, got {fmt}")
    if fmt == "parquet":
        _need_pyarrow()
    paths = []
    for name, table in run_tables(log).items():
        path = out_dir / f"{name}.{fmt}"
        write_table(table, fmt, path)
        paths.append(path)
    return paths


def write_table(table: pd.DataFrame, fmt: str, path: Path) -> None:
    """One table as CSV (no index; NaN as an empty field) or Parquet (pyarrow, no index)."""
    if fmt == "csv":
        table.to_csv(path, index=False)
    else:
        table.to_parquet(path, index=False, engine="pyarrow")


def _need_pyarrow() -> None:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        raise ScenarioError(
            "--format parquet: needs pyarrow, which is not installed (pip install 'cpf-cosim[parquet]')"
        ) from None

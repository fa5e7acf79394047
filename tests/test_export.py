"""`cpf export`: the tables of a run (the very DataFrames of the Python API) to CSV or Parquet, one file per table,
read back equal; pyarrow needed by the Parquet export only; a bad --out refused before any work."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pandas as pd
import pytest

import cpf
from supervisor.analysis.tables import TABLES, run_tables
from tests.conftest import CONFIGS, shortened
from tests.procs import ROOT
from tests.procs import cpf as cpf_command

pytestmark = pytest.mark.e2e


@pytest.fixture(scope="module")
def log(tmp_path_factory) -> Path:
    """20 s of the paper's fleet, 20 % loss and a blackout (drops with their causes, a fault starting and ending)."""
    where = tmp_path_factory.mktemp("export")
    text = shortened((CONFIGS / "paper.toml").read_text(), 20.0).replace("start = 150.0", "start = 15.0")
    cpf.run(text, set={"comms.loss": 0.2}, faults=["kind=blackout,start=5,end=8"], out=where / "run.mcap",
            progress=False)  # fmt: skip
    return where / "run.mcap"


@pytest.fixture(scope="module")
def tables(log) -> dict[str, pd.DataFrame]:
    return run_tables(log)


def test_the_run_has_something_in_every_table(tables):
    assert list(tables) == list(TABLES)
    assert all(len(table) for table in tables.values()), {name: len(t) for name, t in tables.items()}
    assert {"loss", "blackout"} <= set(tables["link_events"].reason.dropna())


def test_csv_reads_back_as_the_tables(log, tables, tmp_path):
    done = cpf_command("export", str(log), "--format", "csv", "--out", "tables", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [f"tables/{name}.csv" for name in TABLES]
    for name, table in tables.items():
        back = pd.read_csv(tmp_path / "tables" / f"{name}.csv")
        expected = table.astype({c: "float64" for c in table.columns if str(table[c].dtype) == "Int64"})
        pd.testing.assert_frame_equal(back, expected, check_dtype=False, check_exact=True, obj=name)


def test_parquet_reads_back_as_the_tables_with_their_types(log, tables, tmp_path):
    done = cpf_command("export", str(log), "--format", "parquet", "--out", "tables", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    for name, table in tables.items():
        pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "tables" / f"{name}.parquet"), table, obj=name)


BLOCKED = "import sys; sys.modules['pyarrow'] = None; from supervisor.cli import main; sys.exit(main(sys.argv[1:]))"


def _without_pyarrow(*args: str, cwd: Path) -> tuple[int, str]:
    """cpf in a Python where `import pyarrow` fails (as where it is not installed): exit code, stderr."""
    import subprocess

    done = subprocess.run([sys.executable, "-c", BLOCKED, *args], cwd=cwd, capture_output=True, text=True, timeout=120)
    return done.returncode, done.stderr


def test_csv_needs_no_pyarrow_and_parquet_says_it_does(log, tmp_path):
    code, err = _without_pyarrow("export", str(log), "--format", "csv", "--out", "csv", cwd=tmp_path)
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "csv").iterdir()) == sorted(f"{name}.csv" for name in TABLES)
    code, err = _without_pyarrow("export", str(log), "--format", "parquet", "--out", "pq", cwd=tmp_path)
    assert (code, err) == (2, "cpf: error: --format parquet: needs pyarrow, which is not installed (pip install "
                              "'cpf-cosim[parquet]')\n")  # fmt: skip
    assert not any((tmp_path / "pq").iterdir())


def test_only_the_parquet_export_imports_pyarrow():
    """pandas imports pyarrow itself when it is installed; of ours, only supervisor/tools/export.py asks for it."""
    importers = []
    for path in sorted(p for package in ("cpf", "supervisor") for p in (ROOT / package).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            names += [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            if any(name.split(".")[0] == "pyarrow" for name in names):
                importers.append(str(path.relative_to(ROOT)))
    assert importers == ["supervisor/tools/export.py"]


@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("afile", "--out: not a directory, got afile"),
        ("afile/sub", "--out: cannot make the directory (Not a directory), got afile/sub"),
        ("/proc/x", "--out: cannot make the directory (No such file or directory), got /proc/x"),
    ],
)
def test_a_bad_out_is_one_line_and_exit_2(log, tmp_path, out, message):
    (tmp_path / "afile").write_text("mine")
    done = cpf_command("export", str(log), "--out", out, cwd=tmp_path)
    assert (done.returncode, done.stderr, done.stdout) == (2, f"cpf: error: {message}\n", "")
    assert (tmp_path / "afile").read_text() == "mine"


def test_a_missing_log_is_refused_before_the_directory_is_made(tmp_path):
    done = cpf_command("export", "none.mcap", "--out", "tables", cwd=tmp_path)
    assert (done.returncode, done.stderr) == (2, "cpf: error: none.mcap: no such log file\n")
    assert not (tmp_path / "tables").exists()

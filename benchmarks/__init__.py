"""The benchmarks of cpf-cosim (`make bench`: benchmarks/__main__.py); each writes its numbers under RESULTS."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


def save(name: str, results: Any) -> Path:
    """Write results to benchmarks/results/<name>.json (the directory made if need be); the file written."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps(results, indent=2))
    return path


def best_of(values: list[float]) -> dict[str, Any]:
    """Repeated timings (s) as the benchmarks quote them: the best, the spread (max - min) and every run."""
    return {"best_s": min(values), "spread_s": max(values) - min(values), "runs_s": list(values)}

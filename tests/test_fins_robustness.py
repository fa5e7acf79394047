"""scripts/fins_robustness.py's table (README, "Robust vehicles"): it counts the vehicles out of the tube, those of
them whose fins cannot hold their trim, those named yet in the tube, and the worst of the rest, as its header says."""

from __future__ import annotations

import importlib.util

from tests.conftest import ROOT

_SPEC = importlib.util.spec_from_file_location("fins_robustness", ROOT / "scripts" / "fins_robustness.py")
assert _SPEC is not None and _SPEC.loader is not None
STUDY = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(STUDY)


def test_the_table_separates_what_the_fins_cannot_hold_from_what_the_controller_did():
    results = {
        (1.0, 0.2, 0): ({1: 0.1, 2: 30.0, 3: 0.5}, 0.01, [2]),  # 2 out, named
        (1.0, 0.2, 1): ({1: 5.0, 2: 0.9, 3: 0.2}, 0.2, [2]),  # 1 out, not named; 2 named, in the tube
        (1.5, 0.2, 0): ({1: 0.0, 2: 0.0, 3: 0.0}, 0.0, []),
    }
    rows = STUDY.table(results)
    assert rows[2] == "| 1 | 0.2 | 0/2 | 1/2 | 2 | 1 | 1 | 5 |"
    assert rows[3] == "| 1.5 | 0.2 | 1/1 | 1/1 | 0 | 0 | 0 | 0 |"

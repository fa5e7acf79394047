"""Restructurings keep results bit-identical: every reference run (the paper scenario, paper_acoustic, a 20-seed fault
soak; tests/run_digest.py) records exactly what the code recorded when tests/data/run_digests.json was written.

A change meant to change results regenerates the file (`python -m tests.run_digest`) and says so in its commit.
"""

from __future__ import annotations

import json

import pytest

from tests.run_digest import FIXTURE, reference_runs, run_and_digest

EXPECTED = json.loads(FIXTURE.read_text())
RUNS = reference_runs()


def test_the_fixture_covers_every_reference_run():
    assert sorted(EXPECTED) == sorted(RUNS)


@pytest.mark.parametrize("name", sorted(RUNS))
def test_a_reference_run_records_what_it_recorded_before(tmp_path, name):
    text, extra = RUNS[name]
    assert run_and_digest(name, text, extra, tmp_path) == EXPECTED[name]

"""Every transmission on the books (issue 30, item 2): on the run with one fault of every kind (the session's
every_kind_runs, both engines), each tx record counts on every link of the base graph and of the graph in force as
sent or as not sent with its cause, tx = sent + not_sent per link, none unaccounted, and the engines agree."""

from __future__ import annotations

import json
from typing import Any

from supervisor.analysis.report import write_report
from supervisor.analysis.tx_books import TxBook, balanced, transmission_books
from supervisor.record.logfile import read_messages


def _tx_records(log: Any) -> dict[int, int]:
    counts: dict[int, int] = {}
    for topic, _, _ in read_messages(log, lambda topic: topic.endswith("/tx")):
        vid = int(topic.split("/")[2])
        counts[vid] = counts.get(vid, 0) + 1
    return counts


def test_every_transmission_of_every_fault_kind_is_on_the_books_of_both_engines(every_kind_runs):
    books: dict[str, dict[tuple[int, int], TxBook]] = {}
    for engine in ("zenoh", "inprocess"):
        log, done = every_kind_runs[engine]
        assert done.returncode == 0, done.stderr
        books[engine] = transmission_books(log)
        made = _tx_records(log)
        assert balanced(books[engine])
        assert not any(b.not_sent["unaccounted"] for b in books[engine].values())
        for (sender, receiver), book in books[engine].items():
            if (sender, receiver) in {(1, 2), (2, 1), (1, 3), (3, 1)}:  # base graph: every tx of its sender
                assert book.tx == made[sender], (sender, receiver)
        causes = set().union(*(b.not_sent for b in books[engine].values()))
        assert causes == {"sender_killed", "broker_down", "not_in_graph", "receiver_down"}
    assert {k: b.as_dict() for k, b in books["zenoh"].items()} == {
        k: b.as_dict() for k, b in books["inprocess"].items()
    }
    inp = books["inprocess"]
    assert inp[(1, 2)].not_sent["receiver_down"] == 31  # vehicle 2 killed 41-44 s: 30 steps, and the restart's
    assert inp[(1, 3)].not_sent["not_in_graph"] == 50  # the graph switch to 1-2, 2-3 for 5 s
    assert inp[(2, 1)].not_sent["sender_killed"] == 1  # its last packet before the kill


def test_the_report_writes_the_books(every_kind_runs, tmp_path):
    log, _ = every_kind_runs["inprocess"]
    write_report(log, tmp_path)
    written = json.loads((tmp_path / "metrics.json").read_text())["transmissions"]
    assert written["2->1"]["tx"] == written["2->1"]["sent"] + sum(written["2->1"]["not_sent"].values())
    assert written["1->3"]["not_sent"]["not_in_graph"] == 50

"""A client's last puts reach a session that answers flushes although the client closes right after them
(comms.bus.bus.flush).

client: put x50, flush, close  --tcp-->  router [subscriber cpf/**, answers flushes]
"""

from __future__ import annotations

import threading

import pytest
import zenoh

from comms.bus.bus import Publishers, answer_flushes, flush, free_port, open_session
from comms.records.messages import decode

pytestmark = pytest.mark.integration

TRIALS = 300  # without flush, 1 to 19 of 300 trials lost some (five batches of 300 on Zenoh 1.10, 2 cores)
PUTS = 50
WAIT = 10.0  # s for the router's callback to take in what it has read (it takes well under 0.1 s)


def puts_then_close(endpoint: str) -> None:
    with open_session("client", connect=[endpoint]) as client:
        publishers = Publishers(client)
        for i in range(PUTS):
            publishers.put(f"cpf/test/{i % 7}", {"i": i})
        flush(client)


def test_every_put_before_a_flush_arrives_though_the_session_closes_right_after() -> None:
    lost = []
    for trial in range(TRIALS):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        with open_session("router", listen=[endpoint]) as router:
            arrived: list[int] = []
            all_in = threading.Event()

            def on_sample(sample: zenoh.Sample, arrived: list[int] = arrived, all_in: threading.Event = all_in) -> None:
                arrived.append(decode(sample.payload.to_bytes())["i"])
                if len(arrived) == PUTS:
                    all_in.set()

            router.declare_subscriber("cpf/**", on_sample)
            answer_flushes(router)  # as the supervisor's session does
            puts_then_close(endpoint)
            # The router has read them all; its Python callback runs on a thread of its own and may still be taking
            # them in. Without flush, the missing ones never came (0.5 s later, under load, 9 of 50 in one trial).
            if not all_in.wait(WAIT):
                lost.append((trial, PUTS - len(arrived)))
            else:
                assert sorted(arrived) == list(range(PUTS))
    assert lost == []

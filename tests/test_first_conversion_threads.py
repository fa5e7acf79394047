"""A vehicle host's threads read their first messages at once (issue 26's 100-AUV runs: 3 of 12 ended with a host
killed by SIGSEGV at t = 0): msgspec (0.22) builds a struct type's conversion info on its first conversion, and
threads racing there crash the process. comms.records.fields.read_as makes each type's first conversion under a
lock. Each trial is a fresh interpreter (the info is built once per process); without the lock 24 of 40 crashed."""

from __future__ import annotations

import subprocess
import sys

RACE = """
import sys, threading
sys.setswitchinterval(1e-6)  # a thread switch at every chance: the race, every time it can happen
from comms.records.fields import read_as
from comms.records.receptions import RxBatch
message = {"t": 0.1, "k": 1, "vehicle": 3, "receptions": [
    {"sender": 1, "seq": 2, "stamp": 0.0, "arrival": 0.05, "gamma": 1.0, "gamma_dot": 0.1}]}
start = threading.Barrier(50)
def first_messages():
    start.wait()
    for _ in range(3):
        assert read_as(message, RxBatch).receptions[0].seq == 2
threads = [threading.Thread(target=first_messages) for _ in range(50)]
for thread in threads: thread.start()
for thread in threads: thread.join()
"""
TRIALS = 10  # at 24 of 40 crashing, ten clean trials by chance: 0.4 ** 10 = 1e-4


def test_fifty_threads_reading_their_first_message_at_once_never_crash() -> None:
    for trial in range(TRIALS):
        done = subprocess.run([sys.executable, "-c", RACE], capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, f"trial {trial}: exit {done.returncode} {done.stderr[-500:]}"

"""CPU cost of recording one message to MCAP: `.venv/bin/python -m benchmarks.bench_record`.

The messages are every message of a paper run (in-process engine, recorded to a temporary log and read back),
written again in their order, as the engines write them: `before` through mcap's own Writer.add_message (the
recorder until issue 15), `after` through supervisor.record.recorder.Recorder (its fast path,
supervisor.record.fast_mcap). Both encode JSON with orjson, check the time and finish a chunk every
FLUSH_INTERVAL of wall time. Prints the best of --rounds in us per message and writes
benchmarks/results/record.json.
"""

from __future__ import annotations

import argparse
import io
import tempfile
import time
from pathlib import Path
from typing import Any

import orjson
from mcap.writer import CompressionType, Writer

from benchmarks import ROOT, save
from supervisor.config.scenario import load_scenario
from supervisor.engine.inprocess import run_inprocess
from supervisor.engine.progress import Progress
from supervisor.record.logfile import read_messages
from supervisor.record.recorder import CHUNK_BYTES, FLUSH_INTERVAL, JSON_OPTIONS, SEQUENCES, Recorder

Logged = list[tuple[str, float, dict[str, Any]]]


def logged(path: Path) -> Logged:
    """(topic, t s, message) of every message of a run of the scenario at path, in the log's order."""
    scenario = load_scenario(path)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.mcap"
        run_inprocess(scenario, str(path), path.read_text(), out, 0, Progress(1.0, io.StringIO(), enabled=False))
        return [(topic, ns / 1e9, message) for topic, ns, message in read_messages(out)]


def before(messages: Logged, out: Path) -> float:
    """s to write them as the recorder did through mcap's Writer.add_message."""
    with out.open("wb") as stream:
        writer = Writer(stream, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        writer.start(profile="", library="cpf-cosim")
        channels: dict[str, int] = {}
        deadline, sequence = 0.0, 0
        start = time.perf_counter()
        for key, t, message in messages:
            if not (type(t) is float and 0.0 <= t < 1.8e10):
                continue
            data = orjson.dumps(message, option=JSON_OPTIONS)
            if key not in channels:
                channels[key] = writer.register_channel(topic=key, message_encoding="json", schema_id=0)
            stamp, sequence = round(t * 1e9), sequence + 1
            writer.add_message(channel_id=channels[key], log_time=stamp, publish_time=stamp, data=data,
                               sequence=sequence % SEQUENCES)  # fmt: skip
            if time.monotonic() >= deadline:
                writer.flush()
                deadline = time.monotonic() + FLUSH_INTERVAL
        writer.finish()
        return time.perf_counter() - start


def after(messages: Logged, out: Path) -> float:
    """s to write them through the Recorder."""
    with Recorder(out) as rec:
        start = time.perf_counter()
        for key, t, message in messages:
            rec.write(key, t, message)
        rec.close()
        return time.perf_counter() - start


def measure(path: Path, rounds: int) -> dict[str, Any]:
    messages = logged(path)
    best: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(rounds):  # alternating: load on the machine hits both alike
            for name, write in (("before", before), ("after", after)):
                spent = write(messages, Path(tmp) / f"{name}.mcap")
                best[name] = min(best.get(name, spent), spent)
    row: dict[str, Any] = {"scenario": str(path), "messages": len(messages), "rounds": rounds}
    row.update({f"{name}_us_per_message": s / len(messages) * 1e6 for name, s in best.items()})
    row.update({f"{name}_s_per_run": s for name, s in best.items()})
    return row


def summary(row: dict[str, Any]) -> str:
    return (
        f"recording {row['messages']} messages: before {row['before_us_per_message']:.2f} us per message "
        f"({row['before_s_per_run']:.2f} s per run), after {row['after_us_per_message']:.2f} us "
        f"({row['after_s_per_run']:.2f} s), best of {row['rounds']}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenario", nargs="?", type=Path, default=ROOT / "configs" / "paper.toml")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    row = measure(args.scenario, args.rounds)
    print(summary(row))
    save("record", row)


if __name__ == "__main__":
    main()

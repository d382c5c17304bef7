"""Benchmark: simulated logging and record reads through the pure ALA1 engine (issue 3).

Prints:
1. a year of module time for 12 channels sampled every minute, with averaging (10 samples)
   and change conditions on: wall-clock seconds, samples and rows per second (issue 11's
   goal: a year in at most 5 s), best and median of ``--runs`` years;
2. the cost of ``read record 1000 from date/.../`` on a full 1 MiB cyclic record;
3. bytes per second of ``read record 100000 from start``.

Run: ``.venv/bin/python benchmarks/bench_sampling.py [--runs N]`` (``make bench`` runs every
benchmark).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from sondalog.ala1 import Engine, Identity, Version
from sondalog.ala1.record import row_key
from sondalog.backends.sim.logger import Analog, SimHardware
from sondalog.backends.sim.signals import RandomWalk, sine
from sondalog.backends.store.ala1_nv import SqliteNvStore

T0 = 1_000_000_000.0
ADDRESSES = (16, 17, 18, 19, 20, 24)
DAYS = 365


def logger(db: Path) -> tuple[Engine, int]:
    hw = SimHardware(
        analog=[
            Analog(a, sine(1.0, 0.8, 86400.0 / (i + 1), 0.0, T0))
            if i % 2
            else Analog(a, RandomWalk(1.0, 0.01, 60.0, i, T0, lambda v: min(2.4, max(0.0, v))))
            for i, a in enumerate(ADDRESSES)
        ]
    )
    engine = Engine(Identity(Version.V2_10), SqliteNvStore(db), T0, hw)
    return engine, engine.open_line()


def ask(engine: Engine, line: int, command: str, now: float = T0) -> bytes:
    return b"".join(o.data for o in engine.receive(line, command.encode() + b"\r", now))


def configure(engine: Engine, line: int) -> None:
    for command in (
        "write date 20070101000000",
        "write channel max number 12",
    ):
        assert ask(engine, line, command) == b"OK\r\n"
    for ch in range(1, 13):
        for part in (
            f"type 3 write channel {ch} address {ADDRESSES[ch % 6]}",
            f"switch output 0 write channel {ch} format 0.3",
            f"sampling period 000100 write channel {ch} sampling start 20070101000000",
            f"average samples 10 write channel {ch} record change 0.02",
        ):
            assert ask(engine, line, f"write channel {ch} {part}") == b"OK\r\n", part


def one_year(db: Path) -> tuple[float, Engine, int, int]:
    """Wall time of one simulated year, the engine, its line, and the rows written."""
    engine, line = logger(db)
    configure(engine, line)
    first = engine.state.record.next_seq
    start = time.perf_counter()
    for day in range(1, DAYS + 1):  # one advance per simulated day, each a group commit
        engine.advance(T0 + day * 86400)
    elapsed = time.perf_counter() - start
    written = engine.state.record.next_seq - first
    return elapsed, engine, line, written


def bench_year(tmp: Path, runs: int) -> None:
    times = []
    for run in range(runs):
        elapsed, engine, line, written = one_year(tmp / f"year{run}.sqlite")
        times.append(elapsed)
    best, median = min(times), statistics.median(times)
    samples = DAYS * 1440 * 12
    status = ask(engine, line, "read record status", T0 + DAYS * 86400).decode().split()[0]
    rows = len(engine.state.record)
    print("1. one year, 12 channels sampled every minute, averaging 10, change 0.02")
    print(f"   wall time            {best:8.2f} s best, {median:.2f} s median of {runs}", end="")
    print(f"   (goal <= 5 s: {best <= 5.0})")
    print(f"   channel samples / s  {samples / best:12,.0f}")
    print(f"   rows written / s     {written / best:12,.0f}   ({written:,} rows in the year)")
    print(f"   module time speed-up {DAYS * 86400 / best:12,.0f} x")
    print(f"   record               {status} ({rows} rows kept, cyclic 1 MiB)")


def full_record(tmp: Path) -> tuple[Engine, int, float]:
    engine, line = logger(tmp / "full.sqlite")
    configure(engine, line)
    for ch in range(1, 13):
        ask(
            engine, line, f"write channel {ch} average samples 0 write channel {ch} record change 0"
        )
    now = T0
    while "FULL" not in ask(engine, line, "read record status", now).decode():
        now += 86400
        engine.advance(now)
    return engine, line, now


def bench_reads(tmp: Path) -> None:
    engine, line, now = full_record(tmp)
    record = engine.state.record
    rows = len(record)
    middle = row_key(record.rows(rows // 2, 1)[0])[:14]
    runs = 50
    start = time.perf_counter()
    for _ in range(runs):
        answer = ask(engine, line, f"read record 1000 from date/{middle}/", now)
    per_read = (time.perf_counter() - start) / runs
    print(f"2. read record 1000 from date/{middle}/ on a full 1 MiB record ({rows} rows)")
    print(f"   {per_read * 1000:8.2f} ms per command, {len(answer):,} bytes answered")

    start = time.perf_counter()
    answer = ask(engine, line, "read record 100000 from start", now)
    elapsed = time.perf_counter() - start
    print(f"3. read record 100000 from start: {len(answer):,} bytes ({rows} rows)")
    print(
        f"   {elapsed * 1000:8.1f} ms, {len(answer) / elapsed / 1e6:8.1f} MB/s through the engine"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="years simulated (best, median)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bench_year(Path(tmp), max(1, args.runs))
        bench_reads(Path(tmp))


if __name__ == "__main__":
    main()

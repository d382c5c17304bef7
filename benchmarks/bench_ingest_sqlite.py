"""Benchmark: readings per second into the collector's SQLite store (goal >= 50,000/s).

Three figures, each over ``--readings`` readings in batches of ``--batch`` (a download chunk):

- ``write``: :meth:`SqliteStore.write` (``INSERT OR IGNORE``, one transaction per batch);
- ``commit_chunk``: readings plus the source's cursor in one transaction, as the collector
  does it;
- ``parse + commit_chunk``: from the record rows as the logger sends them (12 channels a row),
  through :func:`parse_row` and :func:`rows_to_readings`, the whole host path after the line;
- ``again``: the same readings once more (all ignored as duplicates).

Run: ``.venv/bin/python benchmarks/bench_ingest_sqlite.py [--readings N] [--batch N]``.
"""

from __future__ import annotations

import argparse
import asyncio
import tempfile
import time
from datetime import datetime, timedelta
from pathlib import Path

from sondalog.client.records import parse_row
from sondalog.collect.model import Reading
from sondalog.collect.readings import rows_to_readings
from sondalog.collect.store_sqlite import SqliteStore

T0 = datetime(2007, 1, 1)


def rows(count: int) -> list[str]:
    out = []
    for i in range(count):
        stamp = (T0 + timedelta(seconds=100 * i)).strftime("%Y%m%d%H%M%S")
        fields = ",".join(f"{(i * 7 + ch) % 2500 / 1000:.3f}" for ch in range(12))
        out.append(f"{stamp}.0,1,{fields}")
    return out


def report(label: str, count: int, seconds: float) -> None:
    print(f"  {label:<22} {count:>9,} readings in {seconds:6.2f} s: {count / seconds:>10,.0f}/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--readings", type=int, default=600_000)
    parser.add_argument("--batch", type=int, default=6000)
    args = parser.parse_args()
    lines = rows(args.readings // 12)
    per_batch = max(1, args.batch // 12)
    chunks = [lines[i : i + per_batch] for i in range(0, len(lines), per_batch)]
    print(f"SQLite store, batches of {per_batch * 12} readings:")
    with tempfile.TemporaryDirectory() as tmp:
        batches: list[list[Reading]] = [
            rows_to_readings([parse_row(x) for x in chunk], "000001") for chunk in chunks
        ]
        total = sum(len(b) for b in batches)
        store = SqliteStore(Path(tmp) / "a.sqlite").open_sync()
        report("write", total, asyncio.run(write_all(store, batches)))
        report("again (duplicates)", total, asyncio.run(write_all(store, batches)))
        store.close_sync()

        store = SqliteStore(Path(tmp) / "b.sqlite").open_sync()
        store.add_source("s", "tcp://x:1", "logger")
        started = time.perf_counter()
        for batch in batches:
            store.commit_chunk("s", batch, "20070101000000.0")
        report("commit_chunk", total, time.perf_counter() - started)
        store.close_sync()

        store = SqliteStore(Path(tmp) / "c.sqlite").open_sync()
        store.add_source("s", "tcp://x:1", "logger")
        started = time.perf_counter()
        for chunk in chunks:
            rows_ = [parse_row(x) for x in chunk]
            store.commit_chunk("s", rows_to_readings(rows_, "000001"), rows_[-1].key)
        report("parse + commit_chunk", total, time.perf_counter() - started)
        store.close_sync()
    print("goal: >= 50,000 readings/s")


async def write_all(store: SqliteStore, batches: list[list[Reading]]) -> float:
    """Seconds to hand every batch to the store as a sink."""
    started = time.perf_counter()
    for batch in batches:
        await store.write(batch)
    return time.perf_counter() - started


if __name__ == "__main__":
    main()

"""Benchmark: the dashboard's plot request over a year of 1-minute data (issue 14).

1. Fills a SQLite store with the collector's DDL (:mod:`sondalog.collect.schema`) with one
   logger, ``--channels`` channels sampled every minute for a year (525,600 rows each) and
   another logger beside it, inserting as the collector does (``INSERT OR IGNORE``);
2. serves it with :func:`sondalog.web.serve` (real uvicorn, on a free loopback port);
3. times, end to end over HTTP (query, min/max downsampling, JSON), the plot data of a
   year, a month, a week and a day, and the live stream's per-poll query. Target: a year in
   under a second, at most ~2,000 points per series.

Run: ``.venv/bin/python benchmarks/bench_web.py [--channels N] [--store FILE]`` (an existing
``--store`` file is reused).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import sqlite3
import tempfile
import threading
import time
import urllib.request
from datetime import datetime, timedelta
from pathlib import Path

from sondalog.collect.schema import SQLITE_DDL
from sondalog.web import create_app, serve
from sondalog.web import store as web_store

START = datetime(2025, 1, 1)
MINUTES = 365 * 1440


def fill(path: Path, channels: int) -> None:
    conn = sqlite3.connect(path)
    conn.executescript(SQLITE_DDL)
    conn.execute("PRAGMA journal_mode=WAL")
    t0 = time.perf_counter()
    for logger, chans in (("1001", channels), ("2002", 1)):
        batch: list[tuple[object, ...]] = []
        for m in range(MINUTES):
            stamp = (START + timedelta(minutes=m)).strftime("%Y-%m-%dT%H:%M:%S")
            day = math.sin(2 * math.pi * m / 1440)
            for ch in range(1, chans + 1):
                value = None if m % 10_000 == 7 else round(10 * ch + 5 * day + m / 1e5, 3)
                batch.append((logger, ch, stamp, 0, 1, value, None, f"ch{ch}", "°C"))
            if len(batch) >= 50_000:
                conn.executemany(
                    "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, "
                    "value, text, name, unit) VALUES (?,?,?,?,?,?,?,?,?)",
                    batch,
                )
                batch.clear()
        conn.executemany(
            "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, "
            "value, text, name, unit) VALUES (?,?,?,?,?,?,?,?,?)",
            batch,
        )
        conn.commit()
    rows = conn.execute("SELECT count(*) FROM readings").fetchone()[0]
    conn.close()
    print(f"filled {rows:,} rows in {time.perf_counter() - t0:.1f} s")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--channels", type=int, default=4)
    parser.add_argument("--store", type=Path)
    args = parser.parse_args()
    tmp = tempfile.TemporaryDirectory()
    path = args.store or Path(tmp.name) / "store.sqlite"
    if not path.exists():
        fill(path, args.channels)
    size = path.stat().st_size + sum(
        p.stat().st_size for p in path.parent.glob(path.name + "-*") if p.is_file()
    )
    print(f"store: {path} ({size / 1e6:.0f} MB)")

    db = web_store.connect(path)
    conn = db.conn
    plan = conn.execute(
        "EXPLAIN QUERY PLAN SELECT channel, min(value), max(value) FROM readings WHERE "
        "logger = '1001' AND time >= '2025-03' AND time < '2025-04' AND channel > 0 "
        "GROUP BY channel"
    ).fetchall()
    print("bucket query plan:", "; ".join(str(row[3]) for row in plan))
    t0 = time.perf_counter()
    n = len(web_store.newer(db, "1001", "2025-12-31T23:59:00", 5000))
    print(f"live poll query: {(time.perf_counter() - t0) * 1e3:.2f} ms ({n} rows)")
    conn.close()

    app = create_app(path)
    port: list[int] = []
    loop = asyncio.new_event_loop()
    task = loop.create_task(serve(app, "127.0.0.1", 0, on_listen=lambda h, p: port.append(p)))

    def run() -> None:
        with contextlib.suppress(asyncio.CancelledError):
            loop.run_until_complete(task)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    while not port:
        time.sleep(0.01)
    base = f"http://127.0.0.1:{port[0]}/api/loggers/1001/series"
    for label, days in (("year", 365), ("month", 31), ("week", 7), ("day", 1)):
        frm = (START + timedelta(days=365 - days)).strftime("%Y-%m-%dT%H:%M:%S")
        url = f"{base}?from={frm}&to=2025-12-31T23:59:59"
        best = math.inf
        for _ in range(3):
            t0 = time.perf_counter()
            with urllib.request.urlopen(url) as resp:
                body = resp.read()
            best = min(best, time.perf_counter() - t0)
        data = json.loads(body)
        most = max(len(s["v"]) for s in data["series"])
        print(
            f"{label:>5}: {best * 1e3:7.1f} ms, {len(data['series'])} series, "
            f"<= {most} points each, {len(body) / 1e3:.0f} kB JSON, "
            f"downsampled={data['downsampled']} bucket={data['bucket_s']} s"
        )
    loop.call_soon_threadsafe(task.cancel)
    thread.join(5)
    tmp.cleanup()


if __name__ == "__main__":
    main()

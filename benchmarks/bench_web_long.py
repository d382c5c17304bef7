"""Benchmark: the dashboard's long ranges on SQLite and PostgreSQL (issue 24).

A year of 1-minute readings of 12 channels (6.3 million rows, plus a second logger of one
channel), the plot request of the whole year, a month and a week
(``/api/loggers/1001/series``), served by :func:`sondalog.web.serve` over real uvicorn:

- **server time**: the handler's own time, from the response's ``Server-Timing`` header
  (query, downsampling and JSON; not the HTTP client), best and median of ``--runs``; and
  the CPU time of the request's threads (``cpu``), which other processes' load on a shared
  machine does not inflate (a PostgreSQL server's own CPU is not in it);
- end to end over HTTP, best;
- each store with its per-block extremes (``readings_extremes``, kept by the sinks per batch,
  :mod:`sondalog.collect.blocks_sql`) and, for the year, without them (the rows' path), with
  the time the background filler (:mod:`sondalog.collect.blocks_fill`) took over the rows
  stored without them, and its longest step (how long a writer waits for it at most; on
  PostgreSQL a step takes whole days up to ``STEP_READINGS`` readings).

Run: ``.venv/bin/python benchmarks/bench_web_long.py [--sqlite FILE] [--dsn DSN] [--runs N]``.
An existing ``--sqlite`` file with readings is reused; without ``--dsn`` a throwaway
PostgreSQL server is started (tests/collect/services.py; needs the Debian packages). Only
``--sqlite`` or only ``--dsn``: ``--skip-postgres`` / ``--skip-sqlite``. ``--keep DIR``
keeps both filled stores between runs (filling them takes minutes): the SQLite file
``DIR/store.sqlite`` (unless ``--sqlite``) and a PostgreSQL cluster in ``DIR/pg``, started
for the run and stopped after it (unless ``--dsn``); two trees compared in turn can share
one ``DIR`` (the stores are the same), not run at once.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import itertools
import json
import math
import os
import shutil
import sqlite3
import statistics
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import psycopg

from sondalog.collect import blocks_fill, pg_rows, schema_pg, sink_postgres
from sondalog.web import create_app, serve

START = datetime(2025, 1, 1)
MINUTES = 365 * 1440
CHANNELS = 12


def rows(channels: int = CHANNELS):
    """The readings of bench_web.py: logger 1001 with ``channels``, 2002 with one."""
    for logger, chans in (("1001", channels), ("2002", 1)):
        for m in range(MINUTES):
            when = START + timedelta(minutes=m)
            day = math.sin(2 * math.pi * m / 1440)
            for ch in range(1, chans + 1):
                value = None if m % 10_000 == 7 else round(10 * ch + 5 * day + m / 1e5, 3)
                yield logger, ch, when, value


def fill_sqlite(path: Path) -> None:
    sys.path.insert(0, str(Path(__file__).parent))
    from bench_web import fill

    fill(path, CHANNELS)


def fill_postgres(dsn: str) -> None:
    async def schema() -> None:
        sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
        await sink.open()
        await sink.close()

    asyncio.run(schema())
    t0 = time.perf_counter()
    with psycopg.connect(dsn, autocommit=True) as conn, conn.cursor() as cur:
        if cur.execute("SELECT 1 FROM readings LIMIT 1").fetchone():
            return
        # Schema version 2: one row a record row (the readings of a minute), as the sink
        # writes them (pg_rows); ``readings`` is the view the dashboard reads.
        encoder = pg_rows.Encoder()
        cols = ", ".join(schema_pg.COLUMNS)
        with cur.copy(f"COPY {schema_pg.TABLE} ({cols}) FROM STDIN (FORMAT BINARY)") as copy:
            copy.write(pg_rows.SIGNATURE)
            chunk: list[pg_rows.Row] = []
            for minute in itertools.groupby(rows(), key=lambda r: (r[0], r[2])):
                (logger, when), readings = minute
                got = list(readings)
                n = len(got)
                chunk.append(
                    (logger, when, 0, None, tuple(r[1] for r in got), (1,) * n,
                     tuple(r[3] for r in got), (None,) * n, tuple(f"ch{r[1]}" for r in got),
                     ("°C",) * n)
                )  # fmt: skip
                if len(chunk) == 20_000:
                    copy.write(encoder.body(chunk))
                    chunk = []
            copy.write(encoder.body(chunk) + pg_rows.TRAILER)
        cur.execute(f"ANALYZE {schema_pg.TABLE}")
    print(f"postgres: filled in {time.perf_counter() - t0:.1f} s")


class Served:
    def __init__(self, app: object) -> None:
        self.port: list[int] = []
        self.loop = asyncio.new_event_loop()
        self.task = self.loop.create_task(
            serve(app, "127.0.0.1", 0, on_listen=lambda h, p: self.port.append(p))  # type: ignore[arg-type]
        )
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()
        while not self.port:
            time.sleep(0.01)

    def _run(self) -> None:
        with contextlib.suppress(asyncio.CancelledError):
            self.loop.run_until_complete(self.task)

    def stop(self) -> None:
        self.loop.call_soon_threadsafe(self.task.cancel)
        self.thread.join(10)


def kept_server(services: Any, where: Path) -> Any:
    """A :class:`services.PostgresServer` whose cluster is ``where`` (made the first time),
    started; its database ``bench`` made if missing. ``stop()`` it, do not ``destroy()``."""
    server = services.PostgresServer.__new__(services.PostgresServer)
    server.bin, server.dir, server.data = services._pg_bin(), where, where / "data"
    server.port, server._dbs = services.free_port(), itertools.count(1)
    server._as_user = []
    if os.geteuid() == 0:
        server._as_user = ["runuser", "-u", "nobody", "--"]
    if not server.data.exists():
        where.mkdir(parents=True, exist_ok=True)
        os.chmod(where, 0o755)
        if server._as_user:
            shutil.chown(where, "nobody")
        data = str(server.data)
        server._run(
            "initdb", "-D", data, "-U", "postgres", "-A", "trust", "--no-sync", "-E", "UTF8"
        )
    server.start()
    with psycopg.connect(server.dsn(), autocommit=True) as conn:
        if not conn.execute("SELECT 1 FROM pg_database WHERE datname = 'bench'").fetchone():
            conn.execute("CREATE DATABASE bench")
    return server


def measure(label: str, app: object, runs: int, ranges: tuple[str, ...]) -> None:
    served = Served(app)
    base = f"http://127.0.0.1:{served.port[0]}/api/loggers/1001/series"
    try:
        for name in ranges:
            days = {"year": 365, "month": 31, "week": 7}[name]
            frm = (START + timedelta(days=365 - days)).strftime("%Y-%m-%dT%H:%M:%S")
            url = f"{base}?from={frm}&to=2025-12-31T23:59:59"
            server, cpu, total = [], [], []
            for _ in range(runs):
                t0 = time.perf_counter()
                try:
                    with urllib.request.urlopen(url) as resp:
                        body = resp.read()
                        timing = resp.headers["Server-Timing"]
                except urllib.error.HTTPError as e:  # the store's statement limit (503)
                    took = time.perf_counter() - t0
                    why = e.read()[:200]
                    print(f"{label:>26} {name:>5}: HTTP {e.code} after {took:.1f} s: {why!r}")
                    break
                total.append(time.perf_counter() - t0)
                parts = dict(p.strip().split(";dur=") for p in timing.split(","))
                server.append(float(parts["app"]) / 1e3)
                cpu.append(float(parts["cpu"]) / 1e3)
            if not server:
                continue
            data = json.loads(body)
            most = max(len(s["v"]) for s in data["series"])
            print(
                f"{label:>26} {name:>5}: server best {min(server) * 1e3:6.1f} ms, "
                f"median {statistics.median(server) * 1e3:6.1f} ms; CPU best "
                f"{min(cpu) * 1e3:6.1f} median {statistics.median(cpu) * 1e3:6.1f} ms; HTTP best "
                f"{min(total) * 1e3:6.1f} ms; {len(data['series'])} series <= {most} points, "
                f"bucket {data['bucket_s']} s",
                flush=True,
            )
    finally:
        served.stop()


def drop_sqlite_blocks(path: Path) -> Path:
    """A copy of the store without the blocks (the rows' path)."""
    plain = path.with_name(path.stem + ".plain.sqlite")
    if not plain.exists():
        shutil.copy(path, plain)
        conn = sqlite3.connect(plain)
        conn.execute("DROP TABLE IF EXISTS readings_extremes")
        conn.execute("DROP TABLE IF EXISTS readings_extremes_todo")
        conn.commit()
        conn.close()
    return plain


def fill(label: str, step: Callable[[], bool]) -> None:
    """Run the background filler's steps until done; its time and longest step."""
    t0, steps, worst = time.perf_counter(), 0, 0.0
    while True:
        t1 = time.perf_counter()
        if not step():
            break
        worst = max(worst, time.perf_counter() - t1)
        steps += 1
    if steps:
        print(
            f"{label}: {steps} steps (whole days of a logger each) of blocks filled from rows in "
            f"{time.perf_counter() - t0:.1f} s, longest step {worst * 1e3:.0f} ms",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sqlite", type=Path)
    parser.add_argument("--dsn")
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--skip-sqlite", action="store_true")
    parser.add_argument("--skip-postgres", action="store_true")
    parser.add_argument("--no-rows-path", action="store_true", help="skip the slow old path")
    parser.add_argument("--keep", type=Path, help="keep the filled stores in this directory")
    args = parser.parse_args()
    print("load average: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()), flush=True)
    tmp = tempfile.TemporaryDirectory()
    ranges = ("year", "month", "week")
    if not args.skip_sqlite:
        path = args.sqlite or (args.keep or Path(tmp.name)) / "store.sqlite"
        if args.keep:
            args.keep.mkdir(parents=True, exist_ok=True)
        if not path.exists():
            fill_sqlite(path)
        if not args.no_rows_path:
            measure("sqlite, rows (before)", create_app(drop_sqlite_blocks(path)), 3, ("year",))
        conn = sqlite3.connect(path, isolation_level=None)
        fill("sqlite", lambda: blocks_fill.fill_step_sqlite(conn))
        conn.close()
        measure("sqlite, blocks", create_app(path), args.runs, ranges)
    if not args.skip_postgres:
        server = None
        kept = False
        dsn = args.dsn
        if dsn is None and args.keep is not None:
            sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "collect"))
            import services

            if services._pg_bin() is None:
                print("postgres: no server binaries; skipped")
                return
            server = kept_server(services, args.keep.resolve() / "pg")
            kept = True
            dsn = server.dsn("bench")
        if dsn is None:
            sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "collect"))
            import services

            bindir = services._pg_bin()
            if bindir is None:
                print("postgres: no server binaries; skipped")
                return
            server = services.PostgresServer(bindir)
            server.start()
            dsn = server.create_db()
        try:
            fill_postgres(dsn)
            if not args.no_rows_path:
                with psycopg.connect(dsn, autocommit=True) as conn:
                    has = conn.execute("SELECT to_regclass('readings_extremes')").fetchone()
                if has is None or has[0] is None:
                    app = create_app(None, readings_dsn=dsn)
                    measure("postgres, rows (no blocks)", app, 3, ("year",))
            with psycopg.connect(dsn, autocommit=True) as conn:
                fill("postgres", lambda: blocks_fill.fill_step_postgres(conn))
                # the planner's statistics of the blocks, as autovacuum keeps them on a store
                # in use; a store just filled (kept, started for a minute a run) has none,
                # and the year's statement was sorted instead of hashed (15 ms more)
                if conn.execute("SELECT to_regclass('readings_extremes')").fetchone() != (None,):
                    conn.execute("ANALYZE readings_extremes")
            measure("postgres, blocks", create_app(None, readings_dsn=dsn), args.runs, ranges)
        finally:
            if server is not None and kept:
                server.stop()
            elif server is not None:
                server.destroy()
    tmp.cleanup()


if __name__ == "__main__":
    main()

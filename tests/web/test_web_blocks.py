"""The per-block extremes give exactly what the rows gave (issue 24), on SQLite and PostgreSQL.

The reference is the path the dashboard had (``store.bucketed``: SQLite, one key range per
bucket). Random readings with ties, NULLs, several rows in one second (counters), inserted
in random order and partly twice (``INSERT OR IGNORE``, the sink's ``ON CONFLICT DO
NOTHING``: a row stored once fires the trigger once); random bucket edges of any width. Both
ways of filling the blocks are checked: by the trigger at ingest, and by the install over
rows already stored.
"""

from __future__ import annotations

import asyncio
import json
import random
import sqlite3
import urllib.request
from datetime import datetime, timedelta
from pathlib import Path

import psycopg
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from web_store import Running, make_store

from sondalog.collect import sink_postgres
from sondalog.collect.model import Reading
from sondalog.collect.schema import SQLITE_DDL
from sondalog.web import blocks, create_app, store
from sondalog.web.db import Readings
from sondalog.web.times import from_epoch, to_epoch

T0 = datetime(2026, 3, 1)
Row = tuple[str, int, str, int, int, float | None]


def random_rows(rng: random.Random, n: int, channels: int, span_s: int) -> list[Row]:
    out: list[Row] = []
    for _ in range(n):
        t = (T0 + timedelta(seconds=rng.randrange(span_s))).strftime("%Y-%m-%dT%H:%M:%S")
        for ch in range(1, channels + 1):
            value = rng.choice([None, 1.0, 2.0, 2.0, -3.5, rng.uniform(-5, 5)])
            out.append(("L", ch, t, rng.randrange(3), 1, value))
    return out


def random_edges(rng: random.Random, span_s: int) -> list[str]:
    width = rng.choice([1, 7, 59, 61, 299, 300, 301, 1800, 3599, 3600, 3601, 7300, 40_000])
    start = to_epoch(T0.strftime("%Y-%m-%dT%H:%M:%S")) + rng.randrange(-3600, span_s)
    n = rng.randrange(1, 60)
    return [from_epoch(start + i * width) for i in range(n + 1)]


def sqlite_with(rows: list[Row], *, blocks_first: bool | None) -> sqlite3.Connection:
    """An in-memory store; ``blocks_first`` True: blocks made before the rows (trigger),
    False: after (filled from them), None: no blocks."""
    conn = sqlite3.connect(":memory:", isolation_level=None)
    conn.executescript(SQLITE_DDL)
    if blocks_first:
        blocks.install_sqlite(conn)
    conn.executemany(
        "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value) "
        "VALUES (?, ?, ?, ?, ?, ?)",
        rows,
    )
    if blocks_first is False:
        assert blocks.install_sqlite(conn)
    return conn


def answers(conn: sqlite3.Connection, edges: list[str]) -> list[tuple[object, ...]]:
    """The old path's answer, times in seconds as the new one gives them."""
    old = store.bucketed(conn, "L", edges)
    return sorted(((i, ch, w, v, to_epoch(t)) for i, ch, w, v, t in old), key=repr)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32), n=st.integers(1, 300), channels=st.integers(1, 3))
def test_sqlite_blocks_answer_as_the_rows_did(seed: int, n: int, channels: int) -> None:
    rng = random.Random(seed)
    span = rng.choice([600, 7200, 3 * 86400])
    rows = random_rows(rng, n, channels, span)
    again = [(*r[:5], 99.0) for r in rng.sample(rows, len(rows) // 4)]  # ignored: key taken
    plain = sqlite_with(rows, blocks_first=None)
    with_trigger = sqlite_with(rows + again, blocks_first=True)
    filled = sqlite_with(rows + again, blocks_first=False)
    for _ in range(4):
        edges = random_edges(rng, span)
        want = answers(plain, edges)
        for conn in (plain, with_trigger, filled):
            db = store.of_file(conn)
            assert sorted(blocks.extremes(db, "L", edges), key=repr) == want
        assert store.of_file(with_trigger).has_blocks and not store.of_file(plain).has_blocks


def test_install_is_idempotent_and_the_trigger_keeps_up(tmp_path: Path) -> None:
    conn = sqlite_with(random_rows(random.Random(1), 50, 2, 3600), blocks_first=False)
    assert not blocks.install_sqlite(conn)  # already there
    conn.execute("DROP TRIGGER readings_blocks_add")  # a table without its trigger: not used
    assert not store.of_file(conn).has_blocks
    assert blocks.install_sqlite(conn) and store.of_file(conn).has_blocks
    conn.execute(
        "INSERT INTO readings (logger, channel, time, counter, type, value) "
        "VALUES ('L', 1, '2026-03-01T00:10:00', 7, 1, -1000)"
    )
    edges = ["2026-03-01T00:00:00", "2026-03-01T01:00:00"]
    got = {(w, v, t) for _, ch, w, v, t in blocks.extremes(store.of_file(conn), "L", edges)}
    assert (0, -1000.0, to_epoch("2026-03-01T00:10:00")) in got


# -- PostgreSQL ---------------------------------------------------------------------------


def _reading(r: Row) -> Reading:
    return Reading(r[0], r[1], datetime.fromisoformat(r[2]), r[3], r[4], r[5])


async def _write(dsn: str, rows: list[Row]) -> None:
    sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
    await sink.open()
    try:
        for i in range(0, len(rows), 97):
            await sink.write([_reading(r) for r in rows[i : i + 97]])
    finally:
        await sink.close()


def _install(dsn: str) -> bool:
    with psycopg.connect(dsn, autocommit=True) as conn:
        return blocks.install_postgres(conn)


@pytest.mark.parametrize("seed", range(6))
def test_postgres_answers_as_sqlite_did(pg_dsn: str, seed: int) -> None:
    """Written through the real sink (COPY, ``ON CONFLICT DO NOTHING``); blocks made before
    the first half (trigger) and ... compared with and without blocks, against SQLite's
    rows path on the same rows."""
    rng = random.Random(seed)
    span = rng.choice([600, 7200, 3 * 86400])
    rows = random_rows(rng, rng.randrange(1, 400), rng.randrange(1, 4), span)
    plain = sqlite_with(rows, blocks_first=None)
    half = len(rows) // 2
    if seed % 2:  # the trigger from the start
        asyncio.run(_write(pg_dsn, rows[:1]))
        assert _install(pg_dsn)
        asyncio.run(_write(pg_dsn, rows + rows[:half]))
    else:  # filled from stored rows, then the trigger
        asyncio.run(_write(pg_dsn, rows[:half]))
        assert _install(pg_dsn)
        asyncio.run(_write(pg_dsn, rows[half:] + rows[:10]))
    assert not _install(pg_dsn)
    readings = Readings(None, pg_dsn)
    db = readings.open()
    try:
        assert db.has_blocks
        for _ in range(6):
            edges = random_edges(rng, span)
            want = answers(plain, edges)
            assert sorted(blocks.extremes(db, "L", edges), key=repr) == want
            assert sorted(blocks.extremes(db, "L", edges, use_blocks=False), key=repr) == want
    finally:
        readings.close(db)
        readings.shutdown()


def _get(url: str) -> object:
    with urllib.request.urlopen(url, timeout=30) as resp:
        return json.loads(resp.read())


def test_the_dashboard_on_postgres_shows_what_it_shows_on_sqlite(
    tmp_path: Path, pg_dsn: str
) -> None:
    """The same readings in the collector's file and on the server: every reading request
    of the API answers the same (series raw and downsampled, overview, live rows, CSV)."""
    rng = random.Random(7)
    rows = random_rows(rng, 3000, 3, 20 * 86400)
    path = make_store(tmp_path / "store.sqlite")
    sqlite_with(rows, blocks_first=None).close()
    file = sqlite3.connect(path)
    with file:
        file.executemany(
            "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            rows,
        )
    file.close()
    asyncio.run(_write(pg_dsn, rows))
    assert _install(pg_dsn)
    on_file = Running(create_app(path))
    on_server = Running(create_app(path, readings_dsn=pg_dsn))
    try:
        for query in (
            "/api/loggers",
            "/api/loggers/L",
            "/api/loggers/L/series",
            "/api/loggers/L/series?from=2026-03-01&to=2026-03-21",
            "/api/loggers/L/series?from=2026-03-02T01:02:03&to=2026-03-02T09:00:00&points=40",
        ):
            assert _get(on_server.url + query) == _get(on_file.url + query), query
        csv = "/api/loggers/L/readings.csv?from=2026-03-03&to=2026-03-09"
        with (
            urllib.request.urlopen(on_server.url + csv) as a,
            urllib.request.urlopen(on_file.url + csv) as b,
        ):
            assert a.read() == b.read()
    finally:
        on_file.stop()
        on_server.stop()

"""The per-block extremes give exactly what the rows give (issue 24), on SQLite and PostgreSQL.

The reference is the dashboard's old path (``store.bucketed``: SQLite, one key range per
bucket, its own SQL) over the same buckets. Random readings with ties, NULLs, several rows in
one second (counters), written in random order and batches through the real sinks, partly
twice with other values (``INSERT OR IGNORE``, ``ON CONFLICT DO NOTHING``: the stored value
counts); random ranges and budgets (every block size and none). Both ways of filling the
blocks are checked: per batch by the sinks, and by the background filler over rows stored
before (the dashboard reads the rows where it has not come yet).
"""

from __future__ import annotations

import asyncio
import json
import random
import sqlite3
import tempfile
import urllib.request
from datetime import datetime, timedelta
from pathlib import Path

import blocks_rows
import psycopg
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from web_store import Running, make_store

from sondalog.collect import blocks_fill, blocks_sql, sink_postgres
from sondalog.collect.model import Reading
from sondalog.collect.schema import SQLITE_DDL
from sondalog.collect.store_sqlite import SqliteStore
from sondalog.collect.web_config import parse_web
from sondalog.config import ConfigError, of
from sondalog.web import blocks, create_app, series, store
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


def random_plan(rng: random.Random, span_s: int) -> blocks.Plan:
    start = to_epoch(T0.strftime("%Y-%m-%dT%H:%M:%S")) + rng.randrange(-3600, span_s)
    length = rng.choice([1, 59, 3601, 7300, 40_000, 86_400 * 3, 86_400 * 40])
    length = rng.randrange(1, length + 1)
    buckets = rng.choice([1, 2, 5, 30, 100, 1000])
    return blocks.plan(from_epoch(start), from_epoch(start + length), buckets)


def reading(r: Row) -> Reading:
    return Reading(r[0], r[1], datetime.fromisoformat(r[2]), r[3], r[4], r[5])


def batches(rows: list[Row], rng: random.Random) -> list[list[Row]]:
    out, i = [], 0
    while i < len(rows):
        n = rng.choice([1, 3, 12, 97, 500])
        out.append(rows[i : i + n])
        i += n
    return out


def plain(rows: list[Row]) -> sqlite3.Connection:
    """An in-memory store of ``rows`` without blocks (the reference)."""
    conn = sqlite3.connect(":memory:", isolation_level=None)
    conn.executescript(SQLITE_DDL)
    conn.executemany(
        "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value) "
        "VALUES (?, ?, ?, ?, ?, ?)",
        rows,
    )
    return conn


def through_sink(path: Path, groups: list[list[Row]]) -> None:
    """``groups`` written by the real SQLite store, a batch each (its hook keeps the blocks)."""

    async def run() -> None:
        sink = SqliteStore(path)
        await sink.open()
        try:
            for group in groups:
                await sink.write([reading(r) for r in group])
        finally:
            await sink.close()

    asyncio.run(run())


def answers(conn: sqlite3.Connection, p: blocks.Plan) -> list[tuple[object, ...]]:
    """The old path's answer over the buckets of ``p``, as :func:`blocks_rows.rows` gives it."""
    cells: dict[tuple[int, int], dict[int, tuple[object, int]]] = {}
    for i, ch, w, v, t in store.bucketed(conn, "L", p.texts()):
        cells.setdefault((ch, i), {})[w] = (v, to_epoch(t))
    return [(i, ch, *c[0], *c[1]) for (ch, i), c in sorted(cells.items())]


def fill(conn: sqlite3.Connection, steps: int | None = None) -> int:
    done = 0
    while (steps is None or done < steps) and blocks_fill.fill_step_sqlite(conn):
        done += 1
    return done


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32), n=st.integers(1, 300), channels=st.integers(1, 3))
def test_sqlite_blocks_answer_as_the_rows_do(seed: int, n: int, channels: int) -> None:
    rng = random.Random(seed)
    span = rng.choice([600, 7200, 3 * 86400, 50 * 86400])
    rows = random_rows(rng, n, channels, span)
    again = [(*r[:5], 99.0) for r in rng.sample(rows, len(rows) // 4)]  # ignored: key taken
    reference = plain(rows)
    mixed = rows + again
    rng.shuffle(mixed[len(rows) :])
    with tempfile.TemporaryDirectory() as tmp:
        kept = Path(tmp) / "kept.sqlite"  # blocks kept by every batch
        through_sink(kept, batches(mixed, rng))
        before = Path(tmp) / "before.sqlite"  # half stored before the blocks, then filled
        half = len(rows) // 2
        made = sqlite3.connect(before)
        made.executescript(SQLITE_DDL)
        made.executemany(
            "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            rows[:half],
        )
        made.commit()
        made.close()
        through_sink(before, batches(rows[half:] + again, rng))
        conns = [
            sqlite3.connect(kept, isolation_level=None),
            sqlite3.connect(before, isolation_level=None),
        ]
        try:
            assert not blocks_sql.has_sqlite(reference)
            for _ in range(4):
                p = random_plan(rng, span)
                want = answers(reference, p)
                assert blocks_rows.rows(store.of_file(reference), "L", p) == want
                for conn in conns:
                    db = store.of_file(conn)
                    assert db.has_blocks
                    assert (
                        blocks_rows.rows(db, "L", p, use_blocks=True if conn is conns[0] else None)
                        == want
                    )
            fill(conns[1])
            for _ in range(4):
                p = random_plan(rng, span)
                want = answers(reference, p)
                for conn in conns:
                    assert blocks_rows.rows(store.of_file(conn), "L", p, use_blocks=True) == want
        finally:
            for conn in conns:
                conn.close()


def test_the_filler_goes_a_day_at_a_time_newest_first(tmp_path: Path) -> None:
    """Rows stored before the blocks: the first batch notes them to be filled; until the
    filler has passed a range the dashboard reads its rows, and shows the same."""
    rows = random_rows(random.Random(3), 400, 2, 10 * 86400)
    path = make_store(tmp_path / "store.sqlite")
    file = sqlite3.connect(path)
    with file:
        file.executemany(
            "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            rows,
        )
    file.close()
    through_sink(path, [[("L", 1, "2026-03-20T00:00:00", 0, 1, 5.0)]])  # after the rest
    conn = sqlite3.connect(path, isolation_level=None)
    reference = plain([*rows, ("L", 1, "2026-03-20T00:00:00", 0, 1, 5.0)])
    last_day = blocks.plan("2026-03-10T00:00:00", "2026-03-20T00:00:00", 100)
    year = blocks.plan("2026-01-01T00:00:00", "2026-12-31T00:00:00", 100)
    db = store.of_file(conn)
    # the batch that made the tables counts as stored before (its day is filled too)
    assert blocks.usable(db, "L", to_epoch("2026-03-21T00:00:00"))
    assert not blocks.usable(db, "L", to_epoch("2026-03-20T00:00:00"))
    assert blocks_rows.rows(db, "L", year) == answers(reference, year)  # from the rows
    assert fill(conn, 1) == 1 and blocks.usable(db, "L", to_epoch("2026-03-20T00:00:00"))
    assert not blocks.usable(db, "L", last_day.edges[0])
    assert fill(conn, 1) == 1 and blocks.usable(db, "L", to_epoch("2026-03-10T00:00:00"))
    assert not blocks.usable(db, "L", to_epoch("2026-03-09T23:59:59"))
    assert blocks_rows.rows(db, "L", last_day) == answers(reference, last_day)
    assert fill(conn) == 9  # the other nine days of rows (the gap is skipped)
    assert blocks.usable(db, "L", 0) and not fill(conn)
    assert blocks_rows.rows(db, "L", year, use_blocks=True) == answers(reference, year)


def test_the_plan_cuts_on_the_block_grid_and_keeps_the_budget() -> None:
    p = blocks.plan("2025-01-01T00:17:13", "2025-12-31T23:59:59", 1000)
    assert p.size == 21600 and p.m == 1000 and p.edges[0] == to_epoch("2025-01-01T00:17:13")
    assert all(e % 21600 == 0 for e in p.edges[1:-1]) and p.edges[-1] == to_epoch(
        "2026-01-01T00:00:00"
    )
    assert all(b - a in (21600, 43200) for a, b in zip(p.edges[1:-2], p.edges[2:-1], strict=True))
    short = blocks.plan("2025-01-01T00:00:00", "2025-01-02T00:00:00", 1000)
    assert short.size == 0 and short.width == 87  # under 1,000 half-hours: equal buckets
    for hi, n in (
        ("2025-01-01T00:00:01", 5),
        ("2027-01-01T00:00:00", 7),
        ("2025-01-01T07:00:00", 1),
    ):
        q = blocks.plan("2025-01-01T00:00:00", hi, n)
        assert 1 <= q.m <= n and q.edges == sorted(set(q.edges))


def test_the_series_shown_from_blocks_is_the_series_from_rows(tmp_path: Path) -> None:
    """``series.load`` (what the plot gets) from the blocks and from the rows alike."""
    rng = random.Random(11)
    rows = random_rows(rng, 4000, 3, 90 * 86400)
    path = tmp_path / "kept.sqlite"
    through_sink(path, batches(rows, rng))
    conn = sqlite3.connect(path, isolation_level=None)
    db = store.of_file(conn)
    chans = store.channels(db, "L")
    reference = store.of_file(plain(rows))
    for lo, hi, points in (
        ("2026-03-01T00:00:00", "2026-05-30T00:00:00", 2000),
        ("2026-03-03T05:06:07", "2026-04-30T00:00:00", 300),
        ("2026-03-01T00:00:00", "2026-03-09T00:00:00", 100),
    ):
        got, width = series.load(db, "L", chans, lo, hi, points)
        want, width2 = series.load(reference, "L", chans, lo, hi, points)
        assert width == width2 and width is not None
        assert [s.as_json() for s in got] == [s.as_json() for s in want]


def test_blocks_false_is_refused_with_its_reason() -> None:
    assert parse_web(of({"blocks": True}, where="web"), {}).enabled
    with pytest.raises(ConfigError, match="always kept now"):
        parse_web(of({"blocks": False}, where="web"), {})


# -- PostgreSQL ---------------------------------------------------------------------------


async def _write(dsn: str, groups: list[list[Row]]) -> None:
    sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
    await sink.open()
    try:
        for group in groups:
            await sink.write([reading(r) for r in group])
    finally:
        await sink.close()


def _store_plainly(dsn: str, rows: list[Row]) -> None:
    """Rows stored as a collector before issue 24's blocks did (no blocks kept)."""
    asyncio.run(_write(dsn, []))  # the sink makes the schema
    with psycopg.connect(dsn, autocommit=True) as conn, conn.cursor() as cur:
        cur.executemany(
            "INSERT INTO readings (logger, channel, time, counter, type, value) "
            "VALUES (%s, %s, %s, %s, %s, %s) ON CONFLICT DO NOTHING",
            rows,
        )


@pytest.mark.parametrize("seed", range(6))
def test_postgres_answers_as_sqlite_does(pg_dsn: str, seed: int) -> None:
    """Written through the real sink (COPY, ``ON CONFLICT DO NOTHING`` with duplicates of
    other values), half of it before the blocks (then filled); compared with and without
    blocks, against SQLite's rows path on the same rows."""
    rng = random.Random(seed)
    span = rng.choice([600, 7200, 3 * 86400, 50 * 86400])
    rows = random_rows(rng, rng.randrange(1, 400), rng.randrange(1, 4), span)
    reference = plain(rows)
    half = len(rows) // 2
    again = [(*r[:5], 99.0) for r in rng.sample(rows, len(rows) // 4)]
    if seed % 2:  # kept by the sink from the start
        asyncio.run(_write(pg_dsn, batches(rows + again, rng)))
    else:  # half stored before, then the sink, then the filler
        _store_plainly(pg_dsn, rows[:half])
        asyncio.run(_write(pg_dsn, batches(rows[half:] + again, rng)))
    readings = Readings(None, pg_dsn)
    db = readings.open()
    try:
        assert db.has_blocks
        for _ in range(6):
            p = random_plan(rng, span)
            want = answers(reference, p)
            assert blocks_rows.rows(db, "L", p) == want
            assert blocks_rows.rows(db, "L", p, use_blocks=False) == want
        with psycopg.connect(pg_dsn, autocommit=True) as conn:
            while blocks_fill.fill_step_postgres(conn):
                pass
        for _ in range(6):
            p = random_plan(rng, span)
            assert blocks_rows.rows(db, "L", p, use_blocks=True) == answers(reference, p)
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
    file = sqlite3.connect(path)
    with file:
        file.executemany(
            "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            rows,
        )
    file.close()
    asyncio.run(_write(pg_dsn, batches(rows, rng)))
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

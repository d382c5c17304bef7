"""The plot's answer of issue 24's fifth round (blocks merged as they are read, channels from
fewer texts, a long range not counted by channel) is byte for byte the answer before
(``web_before.py``: the old code), on SQLite and PostgreSQL, on random stores.

Random readings of two loggers: channels with NULLs, ties, repeated values, numbers whose
text has an exponent, several rows in one second (counters), text rows (channel 0), names
and units that change, a bars channel and formats in the ``channels`` table; written by the
real sinks (the blocks kept per batch), partly before the blocks were kept (the rows' path
until the filler passes); random ranges (open ends too) and point budgets, so the raw, the
equal-bucket and every block size's path are taken.
"""

from __future__ import annotations

import asyncio
import random
import sqlite3
import tempfile
from collections.abc import Iterator
from datetime import datetime, timedelta
from pathlib import Path

import blocks_rows
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from starlette.responses import JSONResponse
from web_before import body as before

from sondalog.collect import blocks_fill, sink_postgres
from sondalog.collect.model import Reading
from sondalog.collect.schema import SQLITE_DDL
from sondalog.collect.store_sqlite import SqliteStore
from sondalog.web import series, store
from sondalog.web.db import Readings
from sondalog.web.times import from_epoch, to_epoch

T0 = datetime(2026, 3, 1)
VALUES = (None, 1.0, 2.0, 2.0, -3.5, 0.0, 20.25, 0.1 + 0.2, 7.125, -0.5)
RARE = (1e-05, 3.0e17)  # a text with an exponent


def random_readings(rng: random.Random, n: int, span_s: int) -> list[Reading]:
    out: list[Reading] = []
    channels = rng.randrange(1, 5)
    for _ in range(n):
        logger = rng.choice("LLLM")
        second = rng.randrange(span_s)
        if rng.random() < 0.2:  # on a block's edge
            second -= second % rng.choice([1800, 7200, 21600, 86400])
        when = T0 + timedelta(seconds=second)
        counter = rng.randrange(3)
        if rng.random() < 0.05:
            out.append(Reading(logger, 0, when, counter, 3, None, "door"))
        for ch in range(1, channels + 1):
            value = rng.choice([*VALUES, round(rng.uniform(-50, 50), rng.randrange(5))])
            if rng.random() < 0.01:
                value = rng.choice(RARE)
            name, unit = rng.choice([(f"ch{ch}", "°C"), (None, None), (f"c{ch}", "m")])
            out.append(Reading(logger, ch, when, counter, 1, value, None, name, unit))
    return out


def sqlite_store(path: Path, readings: list[Reading], rng: random.Random) -> None:
    """``readings`` through the real SQLite store in random batches, a random part stored
    before the blocks were kept; the ``channels`` table with a bars channel and formats."""
    before = rng.randrange(len(readings) + 1) if rng.random() < 0.5 else 0
    if before:  # as an older collector stored them: no blocks
        conn = sqlite3.connect(path)
        conn.executescript(SQLITE_DDL)
        conn.executemany(
            "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value, "
            "text, name, unit) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
            [
                (
                    r.logger,
                    r.channel,
                    r.time.isoformat(),
                    r.counter,
                    r.type,
                    r.value,
                    r.text,
                    r.name,
                    r.unit,
                )
                for r in readings[:before]
            ],
        )
        conn.commit()
        conn.close()

    async def run() -> None:
        sink = SqliteStore(path)
        await sink.open()
        try:
            rest = readings[before:]
            size = rng.choice([1, 7, 50, 1000])
            for i in range(0, max(len(rest), 1), size):
                await sink.write(rest[i : i + size])
        finally:
            await sink.close()

    asyncio.run(run())
    conn = sqlite3.connect(path)
    for ch in range(1, 5):
        if rng.random() < 0.5:
            typ, form = rng.choice([6, 1, None]), rng.choice(["0.1", "5.3", None])
            conn.execute(
                "INSERT INTO channels VALUES ('L', ?, ?, NULL, ?, ?)", (ch, f"n{ch}", typ, form)
            )
    conn.commit()
    conn.close()
    if rng.random() < 0.5:  # the filler passes (or has not yet)
        conn = sqlite3.connect(path, isolation_level=None)
        while blocks_fill.fill_step_sqlite(conn):
            pass
        conn.close()


def ranges(rng: random.Random, span_s: int) -> Iterator[tuple[str | None, str | None, int]]:
    for _ in range(6):
        start = to_epoch(T0.strftime("%Y-%m-%dT%H:%M:%S")) + rng.randrange(-3600, span_s)
        length = rng.randrange(1, rng.choice([60, 7300, 86_400 * 3, 86_400 * 50]))
        lo, hi = from_epoch(start), from_epoch(start + length)
        yield (
            None if rng.random() < 0.15 else lo,
            None if rng.random() < 0.15 else hi,
            rng.choice([10, 11, 16, 40, 2000]),
        )


def blocks_hold_their_times(db: store.Db) -> None:
    """Every block's tmin and tmax lie in the block: PostgreSQL's blocks, read in no order,
    are put in order by their tmins (``blocks.by_channel``), which is their starts' only so."""
    if not db.has_blocks:
        return
    outside = db.first(
        "SELECT count(*) FROM readings_extremes WHERE NOT (tmin >= start AND "
        "tmin < start + size AND tmax >= start AND tmax < start + size)"
    )
    assert outside == (0,)


def same(db: store.Db, rng: random.Random, span_s: int) -> None:
    blocks_hold_their_times(db)
    for logger in ("L", "M", "nobody"):
        for lo, hi, points in ranges(rng, span_s):
            span = rng.choice([3600, 7 * 86400])
            new = JSONResponse(series.answer(db, logger, lo, hi, points, span)).body
            old = JSONResponse(before(db, logger, lo, hi, points, span)).body
            assert new == old, (logger, lo, hi, points)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32), n=st.integers(0, 400))
def test_sqlite_answers_as_before(seed: int, n: int) -> None:
    rng = random.Random(seed)
    span = rng.choice([600, 2 * 86400, 60 * 86400])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "store.sqlite"
        sqlite_store(path, random_readings(rng, n, span), rng)
        db = store.connect(path)
        try:
            same(db, rng, span)
        finally:
            db.conn.close()


@pytest.fixture(scope="module")
def dsn(postgres: object) -> Iterator[str]:
    """One database for every example (emptied before each)."""
    yield postgres.create_db()  # type: ignore[attr-defined]


@settings(
    max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(seed=st.integers(0, 2**32), n=st.integers(0, 300))
def test_postgres_answers_as_before(dsn: str, seed: int, n: int) -> None:
    """The readings on the server (its blocks kept by the sink, or some filled later), the
    ``channels`` table in the collector's file beside it."""
    import psycopg

    rng = random.Random(seed)
    span = rng.choice([600, 2 * 86400, 60 * 86400])
    readings = random_readings(rng, n, span)

    async def write(rows: list[Reading]) -> None:
        sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
        await sink.open()
        try:
            size = rng.choice([1, 7, 50, 1000])
            for i in range(0, len(rows), size):
                await sink.write(rows[i : i + size])
        finally:
            await sink.close()

    asyncio.run(write([]))  # the schema, the first time
    with psycopg.connect(dsn, autocommit=True) as conn:
        conn.execute("TRUNCATE record_rows")
        conn.execute("DROP TABLE IF EXISTS readings_extremes, readings_extremes_todo")
    asyncio.run(write(readings))
    if readings and rng.random() < 0.5:  # blocks dropped: the rows' path until the filler passes
        cut = to_epoch(T0.strftime("%Y-%m-%dT%H:%M:%S")) + rng.randrange(span)
        with psycopg.connect(dsn, autocommit=True) as conn:
            conn.execute("DELETE FROM readings_extremes WHERE start >= %s", (cut,))
            conn.execute(
                "INSERT INTO readings_extremes_todo VALUES ('L', 2000000000) "
                "ON CONFLICT (logger) DO UPDATE SET below = excluded.below"
            )
            if rng.random() < 0.5:
                while blocks_fill.fill_step_postgres(conn):
                    pass
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "store.sqlite"
        sqlite_store(path, [], rng)
        where = Readings(path, dsn)
        db = where.open()
        try:
            same(db, rng, span)
        finally:
            where.close(db)
            where.shutdown()


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.one_of(
            st.floats(),
            st.floats(-1e6, 1e6).map(lambda x: round(x, 3)),
            st.integers(-100, 100).map(float),
            st.sampled_from([0.1 + 0.2, 1e-05, 20.5, -0.0]),
        ),
        min_size=1,
        max_size=30,
    )
)
def test_the_most_decimals_of_values_are_those_of_each(values: list[float]) -> None:
    """:func:`store.most_decimals` reads the text of all the values at once."""
    assert store.most_decimals(values) == max(map(store.decimals, values))


def test_postgres_blocks_out_of_order_are_put_in_order(
    pg_dsn: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The server's arrays of a channel's blocks are taken in time order only when their
    starts show it: in the server's own order (not asked for) or given backwards, they are
    sorted (the answer is that of the blocks asked for in the key's order)."""
    from sondalog.web import blocks

    rng = random.Random(5)
    readings = [r for r in random_readings(rng, 300, 60 * 86400) if r.logger == "L"]
    asyncio.run(_write(pg_dsn, readings))
    where = Readings(None, pg_dsn)
    db = where.open()
    try:
        plans = [blocks.plan("2026-03-01T05:00:00", "2026-04-20T00:00:00", n) for n in (5, 20, 100)]
        monkeypatch.setattr(blocks, "_KEY_ORDER", "ORDER BY start, channel")
        want = [blocks_rows.rows(db, "L", p, use_blocks=True) for p in plans]
        assert all(p.size for p in plans) and all(want)
        for order in ("", "ORDER BY start DESC, channel"):
            monkeypatch.setattr(blocks, "_KEY_ORDER", order)
            assert [blocks_rows.rows(db, "L", p, use_blocks=True) for p in plans] == want
    finally:
        where.close(db)
        where.shutdown()


async def _write(dsn: str, rows: list[Reading]) -> None:
    sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
    await sink.open()
    try:
        await sink.write([])
        for i in range(0, len(rows), 100):
            await sink.write(rows[i : i + 100])
    finally:
        await sink.close()

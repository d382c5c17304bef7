"""PostgreSQL's own paths of the dashboard's long ranges read ``record_rows`` (schema version
2) and answer exactly what the readings do (issue 24), on random data:

- the block filler (:func:`blocks_fill.fill_step_postgres`: whole days up to a number of
  readings a step, every size in one statement) and the sink's read-back of a batch with
  rows stored already make the very blocks :func:`blocks_rule.aggregate` (the rule in
  Python) makes of the stored readings, whatever the step's bound;
- the plot's buckets from the rows (one statement over the range's record rows) and from
  the blocks with their two ends read from the rows equal the old path's
  (:func:`store.bucketed`, SQLite, one key range per bucket) over the same readings.

Random readings of two loggers with ties, NULLs, several rows in one second (counters) and
a reading of channel 0 (a text row: never in a plot), days apart or together, some on the
edges of blocks; random ranges and budgets (every block size and none).
"""

from __future__ import annotations

import asyncio
import random
import sqlite3
from collections.abc import Iterator
from datetime import datetime, timedelta

import blocks_rows
import psycopg
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_web_blocks import plain

from sondalog.collect import blocks_fill, blocks_rule, sink_postgres
from sondalog.collect.model import Reading
from sondalog.web import blocks, store
from sondalog.web.db import Readings
from sondalog.web.times import from_epoch, to_epoch

T0 = datetime(2026, 3, 1)
LOGGERS = ("L", "M")
Row = tuple[str, int, str, int, int, float | None]


@pytest.fixture(scope="module")
def dsn(postgres: object) -> Iterator[str]:
    """One database for every example (its tables emptied before each)."""
    yield postgres.create_db()  # type: ignore[attr-defined]


def random_rows(rng: random.Random, n: int, channels: int, span_s: int) -> list[Row]:
    out: list[Row] = []
    days = rng.choice([1, 3, span_s // 86400 + 1])  # rows on few days, or anywhere
    for _ in range(n):
        logger = rng.choice(LOGGERS)
        second = rng.randrange(days) * 86400 % max(span_s, 1) + rng.randrange(min(span_s, 86400))
        if rng.random() < 0.2:  # on a block's edge
            second -= second % rng.choice([1800, 7200, 21600, 86400])
        t = (T0 + timedelta(seconds=second)).strftime("%Y-%m-%dT%H:%M:%S")
        counter = rng.randrange(3)
        for ch in range(0 if rng.random() < 0.1 else 1, channels + 1):
            value = rng.choice([None, 1.0, 2.0, 2.0, -3.5, rng.uniform(-5, 5)])
            out.append((logger, ch, t, counter, 1, value))
    return out


def stored(conn: sqlite3.Connection) -> list[Reading]:
    return [
        Reading(lg, ch, datetime.fromisoformat(t), c, ty, v)
        for lg, ch, t, c, ty, v in conn.execute(
            "SELECT logger, channel, time, counter, type, value FROM readings "
            "ORDER BY logger, time, counter, channel"
        )
    ]


def answers(conn: sqlite3.Connection, logger: str, p: blocks.Plan) -> list[tuple[object, ...]]:
    """The old path's answer over the buckets of ``p``, as :func:`blocks_rows.rows` gives it."""
    cells: dict[tuple[int, int], dict[int, tuple[object, int]]] = {}
    for i, ch, w, v, t in store.bucketed(conn, logger, p.texts()):
        cells.setdefault((ch, i), {})[w] = (v, to_epoch(t))
    return [(i, ch, *c[0], *c[1]) for (ch, i), c in sorted(cells.items())]


def random_plan(rng: random.Random, span_s: int) -> blocks.Plan:
    start = to_epoch(T0.strftime("%Y-%m-%dT%H:%M:%S")) + rng.randrange(-3600, span_s)
    length = rng.choice([59, 3601, 7300, 40_000, 86_400 * 3, 86_400 * 40])
    length = rng.randrange(1, length + 1)
    return blocks.plan(from_epoch(start), from_epoch(start + length), rng.choice([1, 5, 100]))


def table(dsn: str) -> set[tuple[object, ...]]:
    with psycopg.connect(dsn) as conn:
        return set(conn.execute("SELECT * FROM readings_extremes"))


def empty(dsn: str) -> None:
    """No readings and no blocks (the blocks' tables made again by the next batch or step)."""
    asyncio.run(write(dsn, []))  # the schema, the first time
    with psycopg.connect(dsn, autocommit=True) as conn:
        conn.execute("TRUNCATE record_rows")
        conn.execute("DROP TABLE IF EXISTS readings_extremes, readings_extremes_todo")


async def write(dsn: str, groups: list[list[Row]]) -> None:
    sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
    await sink.open()
    try:
        for group in groups:
            await sink.write([Reading(*r[:2], datetime.fromisoformat(r[2]), *r[3:]) for r in group])
    finally:
        await sink.close()


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    seed=st.integers(0, 2**32),
    n=st.integers(1, 250),
    channels=st.integers(1, 4),
    step=st.sampled_from([1, 40, 1000, 60_000]),
)
def test_postgres_blocks_and_rows_answer_as_the_readings_do(
    dsn: str, monkeypatch: pytest.MonkeyPatch, seed: int, n: int, channels: int, step: int
) -> None:
    rng = random.Random(seed)
    span = rng.choice([600, 2 * 86400, 9 * 86400, 40 * 86400])
    rows = random_rows(rng, n, channels, span)
    again = [(*r[:5], 99.0) for r in rng.sample(rows, len(rows) // 3)]  # ignored: key taken
    ref = plain(rows)  # the SQLite reference of test_web_blocks
    want = set(blocks_rule.aggregate(stored(ref)))
    empty(dsn)
    half = rng.randrange(len(rows) + 1)
    with psycopg.connect(dsn, autocommit=True) as conn:  # stored before the blocks were kept
        conn.cursor().executemany(
            "INSERT INTO readings (logger, channel, time, counter, type, value) "
            "VALUES (%s, %s, %s, %s, %s, %s) ON CONFLICT DO NOTHING",
            rows[:half],
        )
    # then by the sink: batches of new readings only (merged from the batch), and batches
    # with some stored already (the stored rows of the batch's span read back)
    later, size = rows[half:] + again, rng.choice([5, 40, 1000])
    asyncio.run(write(dsn, [later[i : i + size] for i in range(0, len(later), size)]))
    monkeypatch.setattr(blocks_fill, "STEP_READINGS", step)
    with psycopg.connect(dsn, autocommit=True) as conn:
        steps = 0
        while blocks_fill.fill_step_postgres(conn):
            steps += 1
        assert steps <= len({(r[0], r[2][:10]) for r in rows})  # a day of a logger at most
        assert conn.execute("SELECT count(*) FROM readings_extremes_todo").fetchone() == (0,)
    assert table(dsn) == want
    readings = Readings(None, dsn)
    db = readings.open()
    try:
        assert db.dialect.keys == "record_rows"
        for _ in range(4):
            p = random_plan(rng, span)
            for logger in LOGGERS:
                expected = answers(ref, logger, p)
                assert blocks_rows.rows(db, logger, p) == expected
                assert blocks_rows.rows(db, logger, p, use_blocks=False) == expected
    finally:
        readings.close(db)
        readings.shutdown()

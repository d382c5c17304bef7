"""PostgreSQL schema version 2 (issue 24): one row a record row in ``record_rows``, the view
``readings`` with version 1's columns, the migration of a version-1 database, the merge of a
record row whose readings come in two batches, and the dashboard's queries on the view."""

from __future__ import annotations

import asyncio
from datetime import UTC, datetime, timedelta
from typing import Any

import psycopg
from readings_gen import rows, text_row

from sondalog.collect import schema_pg, sink_postgres
from sondalog.collect.model import Reading
from sondalog.web import series, store
from sondalog.web.db import Readings

T0 = datetime(2026, 1, 1)


async def _write(dsn: str, *batches: list[Reading], writers: int = 1) -> int:
    sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off", "writers": writers})
    await sink.open()
    try:
        for b in batches:
            await sink.write(b)
    finally:
        await sink.close()
    return sink.inserted


def write(dsn: str, *batches: list[Reading], writers: int = 1) -> int:
    return asyncio.run(_write(dsn, *batches, writers=writers))


def stored(dsn: str) -> list[tuple[Any, ...]]:
    with psycopg.connect(dsn) as c:
        return c.execute(
            "SELECT * FROM readings ORDER BY logger, time, counter, channel"
        ).fetchall()


def dashboard(dsn: str) -> dict[str, Any]:
    """What the dashboard reads of each logger: its channels, a series, the CSV rows."""
    readings = Readings(None, dsn)
    db = readings.open()
    try:
        out: dict[str, Any] = {"loggers": store.loggers(db)}
        for logger in out["loggers"]:
            chans = store.channels(db, logger)
            got, width = series.load(
                db, logger, chans, "2026-01-01T00:00:00", "2026-01-02T00:00:00", 20
            )
            out[logger] = (
                chans,
                [s.as_json() for s in got],
                width,
                list(store.rows_for_csv(db, logger, None, None, batch=7)),
            )
        return out
    finally:
        readings.close(db)


def _v1_rows() -> list[tuple[object, ...]]:
    """Version 1 rows, in no particular order: NULL values, a text row, UTC times."""
    out: list[tuple[object, ...]] = []
    for i in range(40):
        t = T0 + timedelta(minutes=i)
        utc = (t - timedelta(hours=1)).replace(tzinfo=UTC) if i % 2 else None
        for ch in (3, 1, 2):
            value = None if (i + ch) % 7 == 0 else 20.5 + ch + i / 10
            out.append(("A", ch, t, 0, 1, value, None, f"T{ch}", "°C", utc))
    out.append(("A", 0, T0 + timedelta(minutes=5), 1, 3, None, "door\topen", None, None, None))
    out += [
        ("B", 1, T0 + timedelta(minutes=i), 0, 2, float(i), None, "x", "V", None) for i in range(9)
    ]
    return out


def _make_v1(dsn: str) -> None:
    with psycopg.connect(dsn, autocommit=True) as c:
        c.execute(schema_pg.DDL_V1)
        c.execute("CREATE INDEX readings_time_brin ON readings USING brin (time)")
        c.execute("CREATE TABLE meta (key text PRIMARY KEY, value text NOT NULL)")
        c.execute("INSERT INTO meta VALUES ('schema_version', '1'), ('layout', 'brin')")
        with c.cursor() as cur:
            cur.executemany(
                "INSERT INTO readings (logger, channel, time, counter, type, value, text, name,"
                " unit, utc) VALUES (%s, %s, %s, %s, %s, %s, %s, %s, %s, %s)",
                _v1_rows(),
            )


def test_version_1_database_is_migrated_on_open(pg_dsn: str) -> None:
    _make_v1(pg_dsn)
    before, shown = stored(pg_dsn), dashboard(pg_dsn)
    assert len(before) == 40 * 3 + 1 + 9
    assert write(pg_dsn) == 0  # the sink connects: the migration
    assert stored(pg_dsn) == before
    assert dashboard(pg_dsn) == shown
    with psycopg.connect(pg_dsn) as c:
        meta = dict(c.execute("SELECT key, value FROM meta").fetchall())
        assert meta == {"schema_version": "2", "layout": "brin"}
        kinds = dict(
            c.execute(
                "SELECT relname, relkind FROM pg_class WHERE relname IN"
                " ('readings', 'record_rows', 'readings_v1', 'record_rows_time_brin')"
            ).fetchall()
        )
        assert kinds == {"readings": "v", "record_rows": "r", "record_rows_time_brin": "i"}
        n, channels = c.execute(
            "SELECT count(*), array_agg(channel ORDER BY time) FROM record_rows"
            " WHERE logger = 'A' AND counter = 0"
        ).fetchone()  # type: ignore[misc]
        assert n == 40 and channels[0] == [1, 2, 3]  # one row a record row, by channel
    # the migrated rows take part in the deduplication like the sink's own
    again = [Reading(*row) for row in _v1_rows()]  # type: ignore[arg-type]
    extra = Reading("A", 4, T0, 0, 1, 1.5, name="T4", unit="V")
    assert write(pg_dsn, again, [*again[:30], extra]) == 1
    assert len(stored(pg_dsn)) == len(before) + 1


def test_readings_of_a_row_in_two_batches_are_merged(pg_dsn: str) -> None:
    """A record row's channels in two batches (or two collectors): the second batch's
    channels join the stored row; a channel stored keeps its reading; counted once."""
    first = rows("M", 0, 30, channels=2)
    later = [
        r for r in rows("M", 0, 40, channels=4) if r.channel >= 3 or r.time == T0
    ]  # channels 3 and 4 of rows 0..39, and channels 1 and 2 of row 0 again (other values?)
    changed = [Reading("M", 1, T0, 0, 1, -99.0, name="T1", unit="°C")]
    assert write(pg_dsn, first, [*later, *changed, text_row("M", 3, "late")]) == 30 * 2 + 40 * 2 + 1
    got = stored(pg_dsn)
    assert len(got) == 30 * 2 + 40 * 2 + 1
    assert {r[5] for r in got if r[1] == 1 and r[2] == T0} == {first[0].value}
    with psycopg.connect(pg_dsn) as c:
        arrays = c.execute(
            "SELECT channel FROM record_rows WHERE logger = 'M' AND counter = 0 ORDER BY time"
        ).fetchall()
    assert [a for (a,) in arrays] == [[1, 2, 3, 4]] * 30 + [[3, 4]] * 10
    # written again (a replay, both ways): nothing new
    assert write(pg_dsn, later, first) == 0


def test_two_collectors_merging_the_same_rows_count_each_reading_once(pg_dsn: str) -> None:
    base = rows("C", 0, 200, channels=1)
    write(pg_dsn, base)
    halves = [
        [r for r in rows("C", 0, 200, channels=4) if r.channel in (2, 3)],
        [r for r in rows("C", 0, 200, channels=4) if r.channel in (3, 4)],
    ]

    async def both() -> list[int]:
        return list(await asyncio.gather(*(_write(pg_dsn, h) for h in halves)))

    assert sum(asyncio.run(both())) == 200 * 3
    assert len(stored(pg_dsn)) == 200 * 4


def test_insert_into_the_view_merges_and_keeps_the_stored(pg_dsn: str) -> None:
    write(pg_dsn, rows("V", 0, 2, channels=2))
    sql = (
        "INSERT INTO readings (logger, channel, time, counter, type, value, name)"
        " VALUES (%s, %s, %s, 0, 1, %s, 'n')"
    )
    with psycopg.connect(pg_dsn, autocommit=True) as c:
        assert c.execute(sql, ("V", 5, T0, 7.0)).rowcount == 1
        assert c.execute(sql, ("V", 1, T0, 7.0)).rowcount == 0  # stored already: kept
        c.execute(sql + " ON CONFLICT DO NOTHING", ("W", 1, T0, 8.0))
        got = c.execute(
            "SELECT channel, value FROM readings WHERE time = %s AND logger IN ('V', 'W')"
            " ORDER BY logger, channel",
            (T0,),
        ).fetchall()
    assert got == [(1, rows("V", 0, 1)[0].value), (2, rows("V", 0, 1)[1].value), (5, 7.0), (1, 8.0)]


def test_the_dashboards_queries_use_the_key(pg_dsn: str) -> None:
    """The queries by logger and time reach ``record_rows``' primary key through the view
    (sequential scans off: a plan that can only scan the table keeps its Seq Scan)."""
    write(pg_dsn, rows("P", 0, 300, channels=3), rows("Q", 0, 10))
    lo, hi = "2026-01-01T00:00:00", "2026-01-01T02:00:00"
    where = f"logger = 'P' AND time >= '{lo}' AND time <= '{hi}' AND channel > 0"
    queries = [
        (
            "loggers",
            "WITH RECURSIVE l(x) AS (SELECT min(logger) FROM record_rows UNION ALL SELECT"
            " (SELECT min(logger) FROM record_rows WHERE logger > x) FROM l"
            " WHERE x IS NOT NULL) SELECT x FROM l",
        ),
        (
            "recent",
            "SELECT channel, time, value FROM readings WHERE logger = 'P'"
            " ORDER BY time DESC, counter DESC LIMIT 30",
        ),
        (
            "count",
            f"SELECT channel, count(*) FROM (SELECT channel FROM readings WHERE {where}"
            " LIMIT 100) r GROUP BY channel",
        ),
        ("raw", f"SELECT time, counter, channel, value FROM readings WHERE {where} ORDER BY time"),
        (
            "csv",
            f"SELECT * FROM readings WHERE logger = 'P' AND time >= '{lo}'"
            " ORDER BY time, counter, channel LIMIT 50",
        ),
        ("newest", "SELECT max(time) FROM record_rows WHERE logger = 'P' AND time < '2027-01-01'"),
    ]
    with psycopg.connect(pg_dsn, autocommit=True) as c:
        c.execute("ANALYZE record_rows")
        c.execute("SET enable_seqscan = off")
        for label, sql in queries:
            plan = "\n".join(r[0] for r in c.execute("EXPLAIN " + sql).fetchall())
            assert "record_rows_pkey" in plan, (label, plan)
            assert "Seq Scan" not in plan and "Sort Key: r.logger" not in plan, (label, plan)

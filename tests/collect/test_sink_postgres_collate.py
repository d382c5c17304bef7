"""PostgreSQL schema version 3 (issue 24): the loggers' names compared byte by byte
(``COLLATE "C"``) in ``record_rows`` and ``readings_extremes``. A version-2 database with rows
and blocks, made by version 2's statements, is migrated when the sink connects: nothing lost,
the dashboard's answers the same, on the database's collation and on an ICU ``en-US`` one
(where ``ORDER BY logger`` would differ: the dashboard sorts its loggers itself)."""

from __future__ import annotations

import asyncio
from datetime import datetime, timedelta
from typing import Any

import psycopg
import pytest
from test_sink_postgres_schema import dashboard

from sondalog.collect import blocks_rule, blocks_sql, schema_pg, sink_postgres
from sondalog.collect.model import Reading

T0 = datetime(2026, 1, 1)
#: Names whose byte order is not a language's order (case, punctuation, accents, digits).
NAMES = ["b", "B-2", "a_1", "A", "Zürich", "ä", "10", "9", "a b"]


def readings(names: list[str], first: int, count: int) -> list[Reading]:
    out: list[Reading] = []
    for k, lg in enumerate(names):
        for i in range(first, first + count):
            t = T0 + timedelta(minutes=7 * i)
            for ch in (1, 2, 3):
                v = None if (i + ch + k) % 5 == 0 else float((i * ch + k) % 4)  # ties, NULLs
                out.append(Reading(lg, ch, t, 0, 1, v, None, f"T{ch}", "°C"))
        out.append(Reading(lg, 0, T0 + timedelta(minutes=7 * first + 1), 1, 3, None, "x"))
    return out


def make_v2(dsn: str, batch: list[Reading]) -> None:
    """A database as version 2 made it, with ``batch`` stored and its blocks."""
    with psycopg.connect(dsn) as c:
        c.execute("CREATE TABLE meta (key text PRIMARY KEY, value text NOT NULL)")
        for sql in schema_pg.statements(0, 2):
            c.execute(sql)
        for sql in schema_pg.layout_ddl(schema_pg.BRIN):
            c.execute(sql)
        c.execute("INSERT INTO meta VALUES ('schema_version', '2'), ('layout', 'brin')")
        with c.cursor() as cur:
            cur.execute(blocks_sql.ensure_postgres_sql()[0])
            for sql in blocks_sql.POSTGRES_DDL:  # version 2's: the database's collation
                cur.execute(sql.replace(schema_pg.LOGGER, "text"))
            cur.executemany(
                "INSERT INTO readings (logger, channel, time, counter, type, value, text, name,"
                " unit, utc) VALUES (%s, %s, %s, %s, %s, %s, %s, %s, %s, %s)",
                [
                    (r.logger, r.channel, r.time, r.counter, r.type, r.value, r.text, r.name,
                     r.unit, r.utc)
                    for r in batch
                ],
            )  # fmt: skip
            for lg in NAMES:
                blocks_sql.update_postgres_sync(cur, lg, 0, 10**10)


def collations(dsn: str) -> dict[str, str | None]:
    with psycopg.connect(dsn) as c:
        got = c.execute(
            "SELECT a.attrelid::regclass::text, co.collname FROM pg_attribute a"
            " LEFT JOIN pg_collation co ON co.oid = a.attcollation AND a.attcollation <> 100"
            " WHERE a.attname = 'logger' AND a.attrelid::regclass::text IN"
            " ('record_rows', 'readings_extremes', 'readings')"
        ).fetchall()
    return dict(got)


def everything(dsn: str) -> tuple[list[Any], list[Any], dict[str, Any]]:
    """Every reading and block (sorted here: the server's order by logger may change) and
    what the dashboard shows."""
    with psycopg.connect(dsn) as c:
        rows = c.execute("SELECT * FROM readings").fetchall()
        blocks = c.execute("SELECT * FROM readings_extremes").fetchall()
    key = repr
    return sorted(rows, key=key), sorted(blocks, key=key), dashboard(dsn)


def write(dsn: str, *batches: list[Reading]) -> int:
    async def go() -> int:
        sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
        await sink.open()
        try:
            for b in batches:
                await sink.write(b)
        finally:
            await sink.close()
        return sink.inserted

    return asyncio.run(go())


def icu_db(dsn: str) -> str:
    """A database beside ``dsn``'s whose collation is ICU's ``en-US`` (skipped without)."""
    name = "icu_" + dsn.rsplit("dbname=", 1)[-1].split()[0]
    with psycopg.connect(dsn, autocommit=True) as c:
        try:
            c.execute(
                f"CREATE DATABASE {name} TEMPLATE template0 ENCODING 'UTF8'"  # type: ignore[arg-type]
                " LOCALE_PROVIDER icu ICU_LOCALE 'en-US' LOCALE 'C.UTF-8'"
            )
        except psycopg.Error as e:
            pytest.skip(f"no ICU collation: {e}")
    return dsn.replace(f"dbname={dsn.rsplit('dbname=', 1)[-1].split()[0]}", f"dbname={name}")


@pytest.mark.parametrize("icu", [False, True])
def test_a_version_2_database_is_migrated_to_byte_order(pg_dsn: str, icu: bool) -> None:
    dsn = icu_db(pg_dsn) if icu else pg_dsn
    first = readings(NAMES, 0, 30)
    make_v2(dsn, first)
    assert set(collations(dsn).values()) == {None}  # the database's
    if icu:  # the server's order by logger is a language's, not Python's
        with psycopg.connect(dsn) as c:
            order = [r[0] for r in c.execute("SELECT logger FROM unnest(%s::text[]) AS l(logger)"
                                             " ORDER BY logger", (NAMES,))]  # fmt: skip
        assert order != sorted(NAMES)
    before = everything(dsn)
    assert len(before[0]) == len(first) and before[1]
    assert write(dsn) == 0  # the sink connects: the migration
    assert collations(dsn) == dict.fromkeys(["record_rows", "readings_extremes", "readings"], "C")
    with psycopg.connect(dsn) as c:
        meta = dict(c.execute("SELECT key, value FROM meta").fetchall())
    assert meta == {"schema_version": str(schema_pg.VERSION), "layout": "brin"}
    assert everything(dsn) == before
    # and the migrated database takes new rows, a replay and rows merged into stored ones
    later = readings(NAMES, 25, 20)
    assert write(dsn, later, first) == len(later) - 5 * 3 * len(NAMES)
    with psycopg.connect(dsn) as c:
        got = c.execute("SELECT logger, channel, time, counter, type, value FROM readings")
        stored_ = [Reading(*r) for r in sorted(got.fetchall(), key=repr)]
        blocks = {
            tuple(b[:4]): tuple(b[4:])
            for b in c.execute("SELECT * FROM readings_extremes").fetchall()
        }
    expected = blocks_rule.aggregate(sorted(stored_, key=lambda r: (r.logger, r.time, r.counter)))
    assert blocks == {b[:4]: tuple(b[4:]) for b in expected}
    assert len(stored_) == len(first) + len(later) - 5 * 3 * len(NAMES)

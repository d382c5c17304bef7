"""TimescaleDB used when present (issue 24, docs/scaling.md): on a server with the extension
the PostgreSQL sink makes ``readings`` a hypertable on ``time`` and stores rows in it once.
Skipped where the extension is not installed (Debian's PostgreSQL has none)."""

from __future__ import annotations

import asyncio

import psycopg
import pytest
from readings_gen import rows

from sondalog.collect import sink_postgres


def test_readings_is_a_hypertable_when_timescaledb_is_there(pg_dsn: str) -> None:
    with psycopg.connect(pg_dsn) as db:
        found = db.execute(
            "SELECT count(*) FROM pg_available_extensions WHERE name = 'timescaledb'"
        ).fetchone()
    if not found or not found[0]:
        pytest.skip("the timescaledb extension is not available on this PostgreSQL")

    async def write() -> sink_postgres.PostgresSink:
        sink = sink_postgres.create({"dsn": pg_dsn})
        await sink.open()
        await sink.write(rows("000001", 0, 50))
        await sink.write(rows("000001", 25, 50))  # half of them again
        await sink.close()
        return sink

    sink = asyncio.run(write())
    assert sink.layout == sink_postgres.HYPERTABLE
    with psycopg.connect(pg_dsn) as db:
        tables = db.execute(
            "SELECT hypertable_name FROM timescaledb_information.hypertables"
        ).fetchall()
        stored = db.execute("SELECT count(DISTINCT (time, counter)) FROM readings").fetchone()
        layout = db.execute("SELECT value FROM meta WHERE key = 'layout'").fetchone()
    assert ("readings",) in tables
    assert layout == ("hypertable",)
    assert stored == (75,) and sink.inserted > 0

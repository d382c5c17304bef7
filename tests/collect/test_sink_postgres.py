"""The PostgreSQL sink against a real PostgreSQL server (issue 13, "The collector")."""

from __future__ import annotations

import asyncio
import dataclasses
import subprocess
import sys
from pathlib import Path

import psycopg
import pytest
import services
from readings_gen import rows, text_row

from sondalog.collect import sink_postgres
from sondalog.collect.buffer import DiskBuffer, deliver, drain
from sondalog.collect.model import Reading, SinkUnavailable
from sondalog.collect.sink_postgres import (
    BRIN,
    HYPERTABLE,
    SchemaTooNew,
    choose_layout,
    migration_plan,
)

HERE = Path(__file__).parent


def count(dsn: str, where: str = "true") -> int:
    with psycopg.connect(dsn) as c:
        row = c.execute(f"SELECT count(*) FROM readings WHERE {where}").fetchone()  # type: ignore[arg-type]
        assert row is not None
        return int(row[0])


def keys(dsn: str) -> set[tuple[str, str, int, int]]:
    with psycopg.connect(dsn) as c:
        got = c.execute("SELECT logger, time, counter, channel FROM readings").fetchall()
    return {(lg, t.isoformat(timespec="seconds"), cnt, ch) for lg, t, cnt, ch in got}


async def write_all(
    dsn: str, *batches: list[Reading], writers: int = 1
) -> sink_postgres.PostgresSink:
    sink = sink_postgres.create({"dsn": dsn, "writers": writers})
    await sink.open()
    try:
        for b in batches:
            await sink.write(b)
    finally:
        await sink.close()
    return sink


# -- the decisions, without a server ------------------------------------------------------


def test_layout_decision() -> None:
    assert choose_layout("auto", True) == HYPERTABLE
    assert choose_layout("auto", False) == BRIN
    assert choose_layout("off", True) == BRIN
    assert choose_layout("on", True) == HYPERTABLE
    with pytest.raises(ValueError, match="not available"):
        choose_layout("on", False)
    with pytest.raises(ValueError, match="auto, on or off"):
        choose_layout("yes", True)


def test_migration_plan() -> None:
    assert migration_plan(0, 1) == [1]
    assert migration_plan(1, 1) == []
    assert migration_plan(1, 3) == [2, 3]
    with pytest.raises(SchemaTooNew):
        migration_plan(2, 1)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({}, "postgres.dsn: required"),
        ({"dsn": "host=x", "bogus": 1}, "postgres.bogus: unknown table or key 'bogus'"),
        ({"dsn": "host=x port"}, "not a valid connection string"),
        ({"dsn": "host=x", "timescaledb": "maybe"}, "timescaledb: must be one of auto, on, off"),
        ({"dsn": "host=x", "connect_timeout": 0}, "connect_timeout"),
        ({"dsn": "host=x", "writers": 0}, "writers: .*from 1 to 8"),
        ({"dsn": "host=x", "writers": 9}, "writers: .*from 1 to 8"),
    ],
)
def test_bad_config_is_refused(table: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        sink_postgres.create(table)


def test_split_by_logger_when_that_shares_out_well() -> None:
    four = [r for i in range(10) for lg in "ABCD" for r in rows(lg, i, 1, channels=2)]
    parts = sink_postgres.split(four, 2)
    assert [sorted({r.logger for r in p}) for p in parts] == [["A", "C"], ["B", "D"]]
    assert sorted(r.key for p in parts for r in p) == sorted(r.key for r in four)
    assert [r for r in parts[0] if r.logger == "A"] == [r for r in four if r.logger == "A"]
    # one logger, or one with most of the batch: slices in the batch's order
    one = rows("A", 0, 10)
    assert sink_postgres.split(one, 2) == [one[:15], one[15:]]
    lopsided = [*rows("A", 0, 30), *rows("B", 0, 2)]
    assert sink_postgres.split(lopsided, 2) == [lopsided[:48], lopsided[48:]]
    assert sink_postgres.split(four, 1) == [four]


# -- against the server --------------------------------------------------------------------


def test_schema_created_with_brin_and_version(pg_dsn: str) -> None:
    batch = [*rows("1001", 0, 10), text_row("1001", 3, "door open\x00")]
    sink = asyncio.run(write_all(pg_dsn, batch))
    assert sink.layout == BRIN  # Debian has no timescaledb
    with psycopg.connect(pg_dsn) as c:
        meta = dict(c.execute("SELECT key, value FROM meta").fetchall())
        assert meta == {"schema_version": "2", "layout": "brin"}
        idx = c.execute(
            "SELECT indexdef FROM pg_indexes WHERE tablename = 'record_rows'"
        ).fetchall()
        assert any('USING brin ("time")' in d or "USING brin (time)" in d for (d,) in idx)
        text = c.execute("SELECT text, type FROM readings WHERE channel = 0").fetchall()
        assert text == [("door open", 3)]
        none = c.execute("SELECT count(*) FROM readings WHERE value IS NULL AND channel > 0")
        assert none.fetchone() == (sum(1 for r in batch if r.channel and r.value is None),)
    assert count(pg_dsn) == len(batch)


def test_same_batch_twice_is_stored_once(pg_dsn: str) -> None:
    batch = rows("1001", 0, 40)
    overlap = rows("1001", 20, 40)  # 20 rows already there, 20 new
    sink = asyncio.run(write_all(pg_dsn, batch, batch, overlap))
    assert count(pg_dsn) == 60 * 3
    assert sink.inserted == 60 * 3
    # a second collector (a new connection, the schema already there) changes nothing
    again = asyncio.run(write_all(pg_dsn, overlap))
    assert again.inserted == 0 and count(pg_dsn) == 60 * 3
    assert keys(pg_dsn) == {r.key for r in batch + overlap}


def test_newer_schema_is_refused(pg_dsn: str) -> None:
    asyncio.run(write_all(pg_dsn, rows("1", 0, 1)))
    with psycopg.connect(pg_dsn) as c:
        c.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    with pytest.raises(SchemaTooNew, match="version 99"):
        asyncio.run(write_all(pg_dsn, rows("1", 1, 1)))
    assert count(pg_dsn) == 3


def test_two_writer_processes_with_overlapping_sources(pg_dsn: str) -> None:
    # Both start on an empty database (they race to create the schema) and write the same
    # logger's rows 100..299 besides their own: every row is stored once.
    cmd = [sys.executable, str(HERE / "pg_writer.py"), pg_dsn]
    a = subprocess.Popen([*cmd, "A", "0", "300"], stdout=subprocess.PIPE, text=True)
    b = subprocess.Popen([*cmd, "A", "100", "300"], stdout=subprocess.PIPE, text=True)
    c = subprocess.Popen([*cmd, "B", "0", "100"], stdout=subprocess.PIPE, text=True)
    outs = [p.communicate(timeout=60)[0] for p in (a, b, c)]
    assert [p.returncode for p in (a, b, c)] == [0, 0, 0]
    assert count(pg_dsn, "logger = 'A'") == 400 * 3
    assert count(pg_dsn, "logger = 'B'") == 100 * 3
    assert sum(int(o) for o in outs) == 500 * 3  # each row inserted by exactly one writer


def test_server_stopped_mid_run_then_restarted(
    postgres: services.PostgresServer, pg_dsn: str, tmp_path: Path
) -> None:
    buf = DiskBuffer(tmp_path / "buffer.sqlite")
    batches = [rows("7", i * 10, 10) for i in range(6)]

    async def run() -> None:
        sink = sink_postgres.create({"dsn": pg_dsn, "connect_timeout": 2})
        await sink.open()
        assert await deliver(buf, sink, batches[0])
        assert await deliver(buf, sink, batches[1])
        postgres.stop()
        try:
            for b in batches[2:5]:
                assert not await deliver(buf, sink, b)  # down: buffered on disk
            with pytest.raises(SinkUnavailable):
                await sink.write(batches[5])
            assert buf.count("postgres") == 3
        finally:
            postgres.start()
        assert await drain(buf, sink) == 3  # reconnected, replayed in order
        assert await deliver(buf, sink, batches[5])
        await sink.close()

    asyncio.run(run())
    assert buf.count("postgres") == 0
    assert count(pg_dsn) == 60 * 3
    assert keys(pg_dsn) == {r.key for b in batches for r in b}


def test_unreachable_server_raises_unavailable() -> None:
    port = services.free_port()  # nothing listens there

    async def run() -> None:
        sink = sink_postgres.create({"dsn": f"host=127.0.0.1 port={port} user=x dbname=x"})
        await sink.open()  # does not fail: the collector starts and buffers
        with pytest.raises(SinkUnavailable, match="cannot connect"):
            await sink.write(rows("1", 0, 1))
        await sink.close()

    asyncio.run(run())


def test_both_write_paths_store_the_same_columns(pg_dsn: str) -> None:
    """New rows go by one COPY into ``readings``; a batch with a row already stored (or a key
    twice) goes through the temporary table and ``ON CONFLICT``: the stored columns are the
    same, each key once."""
    from datetime import UTC, timedelta

    def batch(logger: str) -> list[Reading]:
        out = [
            dataclasses.replace(r, utc=(r.time - timedelta(hours=1)).replace(tzinfo=UTC))
            for r in rows(logger, 0, 30, channels=4)
        ]
        return [*out, text_row(logger, 5, "a\\b\tc\nd\x00é"), text_row(logger, 6, "")]

    fast, slow = batch("FAST"), batch("SLOW")
    sink = asyncio.run(write_all(pg_dsn, fast, slow[7:8], [*slow, slow[3]]))
    assert sink.inserted == len(fast) + len(slow)
    with psycopg.connect(pg_dsn) as c:
        stored = {
            logger: c.execute(
                "SELECT channel, time, counter, type, value, text, name, unit, utc FROM readings"
                " WHERE logger = %s ORDER BY time, counter, channel",
                (logger,),
            ).fetchall()
            for logger in ("FAST", "SLOW")
        }
    assert len(stored["FAST"]) == len(fast)
    assert stored["FAST"] == stored["SLOW"]
    assert ("a\\b\tc\ndé", None) in {(row[5], row[4]) for row in stored["FAST"]}


# -- a large batch split between the writer connections ----------------------------------


def big(logger: str, first: int) -> list[Reading]:
    """More readings than :data:`sink_postgres.SPLIT_AT`: split between the writers."""
    out = rows(logger, first, sink_postgres.SPLIT_AT // 4 + 1, channels=4)
    assert len(out) >= sink_postgres.SPLIT_AT
    return out


def backends(dsn: str) -> int:
    """The sink's connections to the database (besides this one)."""
    with psycopg.connect(dsn) as c:
        row = c.execute(
            "SELECT count(*) FROM pg_stat_activity"
            " WHERE datname = current_database() AND pid <> pg_backend_pid()"
        ).fetchone()
        assert row is not None
        return int(row[0])


def test_large_batch_is_split_and_stored_once(pg_dsn: str) -> None:
    first = [*big("BIG", 0), *big("OTHER", 0)]  # split by logger
    second = big("BIG", 300)  # one logger, in slices; it overlaps the first
    seen: list[int] = []

    async def run() -> sink_postgres.PostgresSink:
        sink = sink_postgres.create({"dsn": pg_dsn, "writers": 2})
        await sink.open()
        await sink.write(first)
        seen.append(backends(pg_dsn))
        await sink.write(first)  # a replay: every row stored already
        await sink.write(second)
        await sink.write(rows("SMALL", 0, 5))
        await sink.close()
        return sink

    sink = asyncio.run(run())
    assert seen == [2]  # both writers took a part
    expected = {r.key for r in first + second + rows("SMALL", 0, 5)}
    assert sink.inserted == len(expected)
    assert count(pg_dsn) == len(expected)
    assert keys(pg_dsn) == expected


def test_one_writer_by_default_does_not_split(pg_dsn: str) -> None:
    async def run() -> None:
        sink = sink_postgres.create({"dsn": pg_dsn})
        await sink.open()
        await sink.write(big("ONE", 0))
        assert backends(pg_dsn) == 1
        await sink.close()

    asyncio.run(run())
    assert count(pg_dsn) == len(big("ONE", 0))


def test_parts_holding_each_others_rows_do_not_fail(pg_dsn: str) -> None:
    """The first part begins with row X and ends with row Y, the second begins with Y and
    ends with X (split in slices, a record row's readings in both parts): each may wait for
    the other at its end (a deadlock the server breaks; the part it rolls back is written
    again once the other is committed): each reading once."""
    body = big("DL", 10)
    half = len(body) // 2
    x, y = rows("DL", 0, 1, channels=1)[0], rows("DL", 1, 1, channels=1)[0]
    batch = [x, *body[:half], y, y, *body[half:], x]
    assert len(batch) % 2 == 0 and batch[len(batch) // 2] == y  # the parts' first rows
    sink = asyncio.run(write_all(pg_dsn, batch, writers=2))
    assert sink.inserted == len(body) + 2
    assert keys(pg_dsn) == {r.key for r in [x, y, *body]}


def test_a_part_lost_with_its_connection_is_written_again_once(pg_dsn: str) -> None:
    """The server ends the second writer's connection: the first part is committed, the
    write raises :class:`SinkUnavailable` (the batch stays in the buffer), and writing the
    batch again stores the second part and skips the first."""
    batch = big("LOST", 0)

    async def run() -> sink_postgres.PostgresSink:
        sink = sink_postgres.create({"dsn": pg_dsn, "writers": 2})
        await sink.open()
        await sink.write(rows("LOST", 5000, 1, channels=1))  # small: one connection
        await sink.write(big("WARM", 0))  # now both
        with psycopg.connect(pg_dsn, autocommit=True) as c:
            pids = [
                pid
                for (pid,) in c.execute(
                    "SELECT pid FROM pg_stat_activity WHERE datname = current_database()"
                    " AND pid <> pg_backend_pid() ORDER BY backend_start"
                ).fetchall()
            ]
            assert len(pids) == 2
            c.execute("SELECT pg_terminate_backend(%s)", (pids[1],))
        with pytest.raises(SinkUnavailable):
            await sink.write(batch)
        assert 0 < count(pg_dsn, "logger = 'LOST'") - 1 < len(batch)  # half of it is there
        await sink.write(batch)
        await sink.close()
        return sink

    sink = asyncio.run(run())
    assert count(pg_dsn, "logger = 'LOST'") == len(batch) + 1
    assert sink.inserted == len(batch) + 1 + len(big("WARM", 0))

"""The store's write-behind (issue 24): what the collector's contacts write waits in memory
and is committed once a ``write_behind`` period, and stores exactly what writing at once
stores; whoever uses the connection sees everything written before, in order."""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.collect import blocks_sql
from sondalog.collect.model import Reading
from sondalog.collect.store_sqlite import SqliteStore

T0 = datetime(2007, 3, 1, 12, 0, 0)
SOURCES = ("a", "b", "c")

READING = st.builds(
    Reading,
    logger=st.sampled_from(["000001", "000002"]),
    channel=st.integers(0, 4),
    time=st.integers(0, 50).map(lambda s: T0 + timedelta(seconds=s)),
    counter=st.integers(0, 2),
    type=st.integers(1, 9),
    value=st.none() | st.floats(-1e6, 1e6, allow_nan=False),
    text=st.none() | st.text("ab ,", max_size=4),
    name=st.none() | st.sampled_from(["Supply", "T"]),
    unit=st.none() | st.sampled_from(["V", "°C"]),
)
STEP = st.one_of(
    st.tuples(
        st.just("chunk"),
        st.sampled_from(SOURCES),
        st.lists(READING, max_size=6),
        st.none() | st.integers(0, 99).map(lambda n: f"200703011200{n:02d}.0"),
    ),
    st.tuples(st.just("state"), st.sampled_from(SOURCES), st.sampled_from(["ok", "offline"])),
    st.tuples(st.just("finish"), st.sampled_from(SOURCES), st.text("xyz", max_size=3)),
    st.tuples(st.just("event"), st.sampled_from(SOURCES), st.text("xyz", max_size=3)),
    st.tuples(st.just("tick")),
    # readings without a cursor or a state column (the flush updates no source for them)
    st.tuples(st.just("bare"), st.sampled_from(SOURCES), st.lists(READING, max_size=3)),
)


def _apply(store: SqliteStore, step: tuple[Any, ...], seen: list[Any]) -> None:
    kind = step[0]
    if kind == "chunk":
        store.commit_chunk(step[1], step[2], step[3], logger="000001", offset_s=1.5)
    elif kind == "bare":
        store.commit_chunk(step[1], step[2], None)
    elif kind == "state":
        store.set_state(step[1], state=step[2])
    elif kind == "finish":
        store.finish(step[1], "download", step[2], state="ok", last_error=None)
    elif kind == "event":
        store.event(step[1], "gap", step[2], time="2007-03-01T12:00:00+01:00")
    else:  # what a reader of the store sees at this moment
        seen.append(
            (
                [store.source(name) for name in SOURCES],
                store.db.execute("SELECT count(*) FROM readings").fetchone()[0],
            )
        )


def _contents(path: Path) -> tuple[Any, ...]:
    with contextlib.closing(sqlite3.connect(path)) as db:
        readings = db.execute("SELECT * FROM readings ORDER BY 1, 2, 3, 4").fetchall()
        sources = db.execute("SELECT * FROM sources ORDER BY name").fetchall()
        events = db.execute("SELECT source, kind, text FROM events ORDER BY id").fetchall()
        blocks = []  # the dashboard's extremes (blocks_sql), kept with the readings
        if blocks_sql.has_sqlite(db):
            blocks = db.execute(f"SELECT * FROM {blocks_sql.TABLE} ORDER BY 1, 2, 3, 4").fetchall()
    return readings, sources, events, blocks


def _run(path: Path, steps: list[tuple[Any, ...]], behind: float | None) -> list[Any]:
    seen: list[Any] = []

    async def main() -> None:
        store = SqliteStore(path).open_sync()
        store.write_behind = behind
        for name in SOURCES:
            store.add_source(name, f"tcp://{name}:1", "logger")
        for step in steps:
            _apply(store, step, seen)
            await asyncio.sleep(0)
        store.close_sync()

    asyncio.run(main())
    return seen


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(steps=st.lists(STEP, max_size=30))
def test_write_behind_stores_what_writing_at_once_stores(
    tmp_path_factory: pytest.TempPathFactory, steps: list[tuple[Any, ...]]
) -> None:
    """Random contacts' writes: readings, sources (cursors, states), events in their order,
    the dashboard's block extremes, and what a reader sees between them, the same with
    write-behind as without."""
    tmp = tmp_path_factory.mktemp("behind")
    at_once = _run(tmp / "now.sqlite", steps, None)
    behind = _run(tmp / "behind.sqlite", steps, 3600.0)  # only closing or a reader commits
    assert behind == at_once
    assert _contents(tmp / "behind.sqlite") == _contents(tmp / "now.sqlite")


def test_the_writes_wait_for_the_period_then_commit_in_one_transaction(tmp_path: Path) -> None:
    path = tmp_path / "s.sqlite"
    outside: list[tuple[int, int]] = []

    def look() -> tuple[int, int]:  # another connection: the dashboard's view
        with contextlib.closing(sqlite3.connect(path)) as db:
            readings = db.execute("SELECT count(*) FROM readings").fetchone()[0]
            events = db.execute("SELECT count(*) FROM events").fetchone()[0]
            return readings, events

    async def main() -> None:
        store = SqliteStore(path).open_sync()
        store.write_behind = 0.2
        store.add_source("a", "tcp://a:1", "logger")
        reading = Reading("000001", 1, T0, 0, 1, 1.0)
        store.commit_chunk("a", [reading], "20070301120000.0", logger="000001")
        store.finish("a", "download", "1 row", state="ok")
        assert store.cursor("a") == "20070301120000.0"  # the store's own reads see it
        outside.append(look())
        await asyncio.sleep(0.4)
        outside.append(look())
        assert not store.pending
        store.close_sync()

    asyncio.run(main())
    assert outside == [(0, 0), (1, 1)]


def test_a_failed_flush_keeps_the_writes_for_the_next(tmp_path: Path) -> None:
    path = tmp_path / "s.sqlite"

    async def main() -> None:
        store = SqliteStore(path).open_sync()
        store.write_behind = 0.05
        store.add_source("a", "tcp://a:1", "logger")
        locker = sqlite3.connect(path, isolation_level=None)
        locker.execute("BEGIN IMMEDIATE")  # another writer holds the file
        store.db.execute("PRAGMA busy_timeout=0")
        store.commit_chunk("a", [Reading("000001", 1, T0, 0, 1, 2.0)], "20070301120000.0")
        await asyncio.sleep(0.2)  # flushes fail: the file is locked
        assert store.pending
        locker.execute("COMMIT")
        locker.close()
        await asyncio.sleep(0.3)
        assert not store.pending
        store.close_sync()

    asyncio.run(main())
    with contextlib.closing(sqlite3.connect(path)) as db:
        assert db.execute("SELECT value FROM readings").fetchall() == [(2.0,)]
        assert db.execute("SELECT cursor FROM sources").fetchall() == [("20070301120000.0",)]

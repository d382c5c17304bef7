"""The collector's SQLite store: schema and version, idempotent inserts, cursors, refusals."""

from __future__ import annotations

import asyncio
import sqlite3
from datetime import datetime
from pathlib import Path

import pytest

from sondalog.collect.model import Reading
from sondalog.collect.schema import SCHEMA_VERSION
from sondalog.collect.sinks import find_sink
from sondalog.collect.store_sqlite import SqliteStore, StoreError, create
from sondalog.config import ConfigError, of

T = datetime(2007, 3, 1, 12, 0, 0)


def _batch(n: int, logger: str = "000001") -> list[Reading]:
    return [
        Reading(
            logger,
            1 + i % 3,
            T.replace(second=i % 60, minute=i // 60),
            0,
            1,
            i * 0.5,
            name="Supply",
            unit="V",
        )
        for i in range(n)
    ]


def test_schema_version_wal_and_idempotent_inserts(tmp_path: Path) -> None:
    store = SqliteStore(tmp_path / "s.sqlite").open_sync()
    asyncio.run(store.write(_batch(100)))
    asyncio.run(store.write(_batch(150)))  # the first 100 again, 50 new
    db = store.db
    assert db.execute("SELECT count(*) FROM readings").fetchone()[0] == 150
    assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert db.execute("SELECT value FROM meta WHERE key='schema_version'").fetchone()[0] == str(
        SCHEMA_VERSION
    )
    row = db.execute("SELECT * FROM readings ORDER BY time LIMIT 1").fetchone()
    assert row == ("000001", 1, "2007-03-01T12:00:00", 0, 1, 0.0, None, "Supply", "V", None)
    store.close_sync()
    again = SqliteStore(tmp_path / "s.sqlite").open_sync()  # reopening keeps everything
    assert again.db.execute("SELECT count(*) FROM readings").fetchone()[0] == 150
    again.close_sync()


def test_cursor_and_readings_commit_together(tmp_path: Path) -> None:
    store = SqliteStore(tmp_path / "s.sqlite").open_sync()
    store.add_source("a", "tcp://x:1", "logger")
    store.commit_chunk("a", _batch(10), "20070301120009.0", logger="000001", offset_s=-2.0)
    assert store.cursor("a") == "20070301120009.0"
    with pytest.raises(ValueError, match="unknown source columns"):
        store.commit_chunk("a", _batch(20), "20070301120019.0", nonsense=1)
    assert store.cursor("a") == "20070301120009.0"  # rolled back with its readings
    assert store.db.execute("SELECT count(*) FROM readings").fetchone()[0] == 10
    store.add_source("a", "tcp://y:2", "logger")  # a changed URL keeps the cursor
    assert store.source("a") == {
        "url": "tcp://y:2",
        "kind": "logger",
        "logger": "000001",
        "state": "new",
        "last_contact": None,
        "last_error": None,
        "offset_s": -2.0,
        "cursor": "20070301120009.0",
        "record_fill": None,
        "signal": None,
        "credit": None,
    }
    store.event("a", "download", "3 rows")
    assert [e[1:] for e in store.events("a")] == [("a", "download", "3 rows")]
    store.close_sync()


def test_refuses_foreign_and_newer_files(tmp_path: Path) -> None:
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE photos (id INTEGER)")
    with pytest.raises(StoreError, match="not a collector store"):
        SqliteStore(other).open_sync()
    text = tmp_path / "text.sqlite"
    text.write_text("hello, this is not a database at all" * 100)
    with pytest.raises(StoreError, match="not a collector store"):
        SqliteStore(text).open_sync()
    newer = tmp_path / "newer.sqlite"
    SqliteStore(newer).open_sync().close_sync()
    with sqlite3.connect(newer) as db:
        db.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    with pytest.raises(StoreError, match="schema version 99"):
        SqliteStore(newer).open_sync()


def test_the_sqlite_sink_by_name(tmp_path: Path) -> None:
    kind = find_sink("sqlite")
    assert kind is not None
    sink = kind.factory(kind.parse(of({"path": "x.sqlite"}, root=tmp_path, where="sqlite")))
    assert isinstance(sink, SqliteStore) and sink.name == "sqlite"
    assert sink.path == tmp_path / "x.sqlite"
    assert find_sink("kafka") is None
    with pytest.raises(ConfigError, match=r"sqlite\.colour: unknown table or key 'colour'"):
        create({"path": "x", "colour": 1})
    with pytest.raises(ConfigError, match=r"sqlite\.readings: must be true or false"):
        create({"path": "x", "readings": 1})

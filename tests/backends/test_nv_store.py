"""One store of a logger's memory, keyed by logger (issue 25): files of the old code still open."""

from __future__ import annotations

import sqlite3
import stat
import threading
import time
from pathlib import Path

import pytest

from sondalog.ala1 import Engine, Identity
from sondalog.ala1.record import RecordChanges
from sondalog.ala1.state import ModuleState
from sondalog.backends.sim.logger import default_hardware
from sondalog.backends.store.ala1_nv import NvDatabase, SqliteNvStore

T0 = 1_000_000_000.0

#: The schema of ``ala1.sqlite`` written by the single logger before issue 25.
OLD_SINGLE_SCHEMA = """
CREATE TABLE IF NOT EXISTS param (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS record (seq INTEGER PRIMARY KEY, row TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS file (area TEXT PRIMARY KEY, data BLOB NOT NULL);
"""

#: The schema of ``fleet.sqlite`` written by the fleet before issue 25.
OLD_FLEET_SCHEMA = """
CREATE TABLE IF NOT EXISTS param (
    logger TEXT NOT NULL, key TEXT NOT NULL, value TEXT NOT NULL, PRIMARY KEY (logger, key));
CREATE TABLE IF NOT EXISTS meta (
    logger TEXT NOT NULL, key TEXT NOT NULL, value TEXT NOT NULL, PRIMARY KEY (logger, key));
CREATE TABLE IF NOT EXISTS record (
    logger TEXT NOT NULL, seq INTEGER NOT NULL, row TEXT NOT NULL, PRIMARY KEY (logger, seq));
CREATE TABLE IF NOT EXISTS file (
    logger TEXT NOT NULL, area TEXT NOT NULL, data BLOB NOT NULL, PRIMARY KEY (logger, area));
"""

META = [
    ("clock_offset", "123.5"),
    ("host_seen", repr(T0)),
    ("record_head", "7"),
    ("record_wrapped", "1"),
    ("record_refused", "0"),
]


def _old_single_file(path: Path) -> None:
    conn = sqlite3.connect(path, isolation_level=None)
    conn.execute("PRAGMA journal_mode=WAL")
    conn.executescript(OLD_SINGLE_SCHEMA)
    conn.execute("INSERT INTO param VALUES ('channel 1 name', 'abc')")
    conn.executemany("INSERT INTO meta VALUES (?, ?)", META)
    conn.executemany("INSERT INTO record VALUES (?, ?)", [(7, "row seven"), (8, "row eight")])
    conn.execute("INSERT INTO file VALUES ('list', ?)", (b"\x01\x02",))
    conn.close()
    path.chmod(0o644)  # as an older version may have left it


def test_a_single_loggers_file_of_the_old_code_opens_and_reads_back(tmp_path: Path) -> None:
    path = tmp_path / "ala1.sqlite"
    _old_single_file(path)
    store = SqliteNvStore(path)
    assert store.load() == ({"channel 1 name": "abc"}, 123.5)
    assert store.last_seen() == T0
    assert store.load_record() == (["row seven", "row eight"], 7, True, False)
    assert store.load_files() == {"list": b"\x01\x02"}
    assert stat.S_IMODE(path.stat().st_mode) == 0o600  # state is private (docs/security.md)
    # the engine's memory over it, and a new write kept across a reopen
    state = ModuleState(Identity(), store, T0)
    assert state.get("channel 1 name") == "abc"
    store.commit({"channel 1 name": "xyz"}, None, RecordChanges([(9, "row nine")], 7, True, False))
    store.close()
    again = SqliteNvStore(path)  # opening a migrated file again changes nothing
    assert again.load() == ({"channel 1 name": "xyz"}, 123.5)
    assert again.load_record() == (["row seven", "row eight", "row nine"], 7, True, False)
    assert again.load_files() == {"list": b"\x01\x02"}
    again.close()


def test_a_fleets_file_of_the_old_code_opens_and_reads_back(tmp_path: Path) -> None:
    path = tmp_path / "fleet.sqlite"
    conn = sqlite3.connect(path, isolation_level=None)
    conn.executescript(OLD_FLEET_SCHEMA)
    for logger in ("F1", "F2"):
        conn.execute("INSERT INTO param VALUES (?, 'channel 1 name', ?)", (logger, logger))
        conn.executemany("INSERT INTO meta VALUES (?, ?, ?)", [(logger, *m) for m in META])
        conn.execute("INSERT INTO record VALUES (?, 7, ?)", (logger, f"row of {logger}"))
    conn.close()
    database = NvDatabase(path, lambda flush: None)
    for logger in ("F1", "F2"):
        store = database.store(logger)
        assert store.load() == ({"channel 1 name": logger}, 123.5)
        assert store.load_record() == ([f"row of {logger}"], 7, True, False)
    assert database.store("F3").load() == ({}, None)  # keys do not leak into each other
    database.close()


def test_a_single_logger_commits_sampled_rows_at_once(tmp_path: Path) -> None:
    """Group commit is the store's to offer: alone, a sampled row is on disk when the
    engine's turn returns (DESIGN.md point 5), through the same ``commit_scheduled``."""
    path = tmp_path / "ala1.sqlite"
    store = SqliteNvStore(path)
    engine = Engine(Identity(), store, T0, default_hardware(T0))
    line = engine.open_line()
    for command in (
        b"write channel max number 1 write channel 1 switch output 0\r",
        b"write channel 1 sampling period 000100 write channel 1 sampling start 20000101000000\r",
    ):
        assert engine.receive(line, command, T0) and engine.receive(line, b"", T0) == []
    reader = sqlite3.connect(path)

    def rows() -> int:
        return int(reader.execute("SELECT count(*) FROM record").fetchone()[0])

    before, transactions = rows(), store.database.transactions
    deadline = engine.next_deadline()
    assert deadline is not None
    engine.advance(deadline)
    assert rows() == before + 1  # durable without anyone flushing
    assert store.database.transactions == transactions + 1
    reader.close()
    store.close()


def test_a_fleet_defers_sampled_rows_to_one_flush(tmp_path: Path) -> None:
    flushes: list[object] = []
    database = NvDatabase(tmp_path / "fleet.sqlite", flushes.append)
    a, b = database.store("A"), database.store("B")
    a.commit_scheduled(RecordChanges([(0, "a0")], 0, False, False), T0)
    b.commit_scheduled(RecordChanges([(0, "b0")], 0, False, False), T0)
    assert len(flushes) == 1 and a.load_record()[0] == []  # waiting for the end of the turn
    database.flush()
    assert a.load_record()[0] == ["a0"] and b.load_record()[0] == ["b0"]
    assert database.transactions == 1
    database.close()


def test_a_batch_is_one_transaction_durable_at_its_end(tmp_path: Path) -> None:
    """A fleet starting (issue 24): every new logger's first commit (its factory clock) is
    in one transaction, visible to nobody before the batch ends; a failure stores none."""
    path = tmp_path / "fleet.sqlite"
    database = NvDatabase(path)
    reader = sqlite3.connect(path)

    def offsets() -> int:
        query = "SELECT count(*) FROM meta WHERE key = 'clock_offset'"
        return int(reader.execute(query).fetchone()[0])

    before = database.transactions
    with database.batch():
        for n in range(50):
            ModuleState(Identity(serial_number=f"B{n}"), database.store(f"B{n}"), T0)
        assert offsets() == 0
    assert offsets() == 50 and database.transactions == before + 1
    with pytest.raises(RuntimeError), database.batch():
        ModuleState(Identity(serial_number="X"), database.store("X"), T0)
        raise RuntimeError("the fleet failed to start")
    assert offsets() == 50
    # after a batch, a commit is durable at once again
    ModuleState(Identity(serial_number="Y"), database.store("Y"), T0)
    assert offsets() == 51
    database.close()


def test_a_fleet_database_checkpoints_in_a_thread_of_its_own(tmp_path: Path) -> None:
    """Issue 24: the fleet's commits never checkpoint the WAL themselves (a checkpoint's
    writes and fsync stopped the event loop); a thread copies it into the file."""
    path = tmp_path / "fleet.sqlite"
    database = NvDatabase(path, checkpoint_every=0.05)
    assert database.conn.execute("PRAGMA wal_autocheckpoint").fetchone()[0] == 0
    empty = path.stat().st_size
    for n in range(200):
        ModuleState(Identity(serial_number=f"C{n}"), database.store(f"C{n}"), T0)
    deadline = time.monotonic() + 10
    while path.stat().st_size <= empty and time.monotonic() < deadline:
        time.sleep(0.05)
    assert path.stat().st_size > empty  # the rows reached the file, not only the WAL
    database.close()
    assert not any(t.name == "sondalog-wal-checkpoint" for t in threading.enumerate())
    reader = sqlite3.connect(path)
    assert (
        reader.execute("SELECT count(*) FROM meta WHERE key = 'clock_offset'").fetchone()[0] == 200
    )


def test_record_pages_take_rows_after_a_gap_and_over_earlier_ones() -> None:
    """A commit's rows go onto the end of their page; rows after a gap (a cyclic record
    dropped every row on disk before they reached it) restart the page; rows over rows of
    the page replace those, the rows after them stay."""
    database = NvDatabase(":memory:")
    store = database.store("L1")

    def commit(head: int, *rows: tuple[int, str]) -> list[tuple[int, str]]:
        store.commit({}, None, RecordChanges(list(rows), head, True, False))
        return database.conn.execute(
            "SELECT seq, row FROM record WHERE logger = 'L1' ORDER BY seq"
        ).fetchall()

    assert commit(3, (3, "a"), (4, "b"), (5, "c")) == [(3, "a"), (4, "b"), (5, "c")]
    assert commit(3, (6, "d")) == [(3, "a"), (4, "b"), (5, "c"), (6, "d")]
    assert commit(9, (9, "x"), (10, "y")) == [(9, "x"), (10, "y")]  # 3..8 dropped
    page = database.conn.execute("SELECT first, count FROM record_page").fetchall()
    assert page == [(9, 2)]
    assert commit(9, (10, "Y")) == [(9, "x"), (10, "Y")]
    assert commit(8, (8, "w")) == [(8, "w"), (9, "x"), (10, "Y")]
    assert store.load_record() == (["w", "x", "Y"], 8, True, False)
    database.close()


def test_a_record_of_a_row_a_database_row_is_moved_into_pages(tmp_path: Path) -> None:
    """A file of before issue 23 (``record`` a table of keyed rows) opens with the same
    record for each logger, in pages; the ``record`` view reads as the table did."""
    path = tmp_path / "fleet.sqlite"
    conn = sqlite3.connect(path, isolation_level=None)
    conn.execute(
        "CREATE TABLE record (logger TEXT NOT NULL, seq INTEGER NOT NULL, row TEXT NOT NULL, "
        "PRIMARY KEY (logger, seq))"
    )
    conn.execute("CREATE TABLE meta (logger TEXT, key TEXT, value TEXT, PRIMARY KEY (logger, key))")
    old = [("F1", seq, f"F1 row {seq}") for seq in range(50, 250)] + [("F2", 0, "F2 row")]
    conn.executemany("INSERT INTO record VALUES (?, ?, ?)", old)
    conn.executemany("INSERT INTO meta VALUES (?, 'record_head', ?)", [("F1", "50"), ("F2", "0")])
    conn.close()
    database = NvDatabase(path)
    assert database.store("F1").load_record()[:2] == ([r for _, _, r in old[:-1]], 50)
    assert database.store("F2").load_record()[:2] == (["F2 row"], 0)
    view = database.conn.execute("SELECT logger, seq, row FROM record ORDER BY 1, 2").fetchall()
    assert view == old
    kinds = dict(database.conn.execute("SELECT name, type FROM sqlite_master"))
    assert kinds["record"] == "view" and kinds["record_page"] == "table"
    database.close()

"""One SQLite database for a fleet of ALA1 modules, with group commit (issue 11).

Served one by one, every logger commits its own transaction, with a full fsync, at every
sampling instant: a thousand loggers sampling on the minute pay a thousand fsyncs a minute.
A fleet shares one database (``fleet.sqlite``, WAL, ``synchronous=FULL``) where every table
carries the logger's key, and one :class:`FleetDatabase` connection:

- the rows a module samples on its own (:meth:`FleetNvStore.commit_scheduled`) wait in memory
  until the end of the event-loop turn, when :meth:`FleetDatabase.flush` writes the rows of
  every logger in **one transaction** (the wiring asks for the flush; this module has no
  event loop);
- anything a command line commits (:meth:`FleetNvStore.commit`: parameters, the clock, rows
  written by a command) is written at once, in one transaction together with whatever waits,
  so it is durable before the line's ``OK`` and never overtakes earlier rows.

The interface is the engine's :class:`~sondalog.ala1.state.NvStore`, like
:class:`~sondalog.backends.store.ala1_nv.SqliteNvStore`.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable
from pathlib import Path

from sondalog.ala1.record import RecordChanges
from sondalog.backends.store.ala1_nv import open_database

SCHEMA = """
CREATE TABLE IF NOT EXISTS param (
    logger TEXT NOT NULL, key TEXT NOT NULL, value TEXT NOT NULL, PRIMARY KEY (logger, key));
CREATE TABLE IF NOT EXISTS meta (
    logger TEXT NOT NULL, key TEXT NOT NULL, value TEXT NOT NULL, PRIMARY KEY (logger, key));
CREATE TABLE IF NOT EXISTS record (
    logger TEXT NOT NULL, seq INTEGER NOT NULL, row TEXT NOT NULL, PRIMARY KEY (logger, seq));
CREATE TABLE IF NOT EXISTS file (
    logger TEXT NOT NULL, area TEXT NOT NULL, data BLOB NOT NULL, PRIMARY KEY (logger, area));
"""

_UPSERT_META = (
    "INSERT INTO meta (logger, key, value) VALUES (?, ?, ?) "
    "ON CONFLICT(logger, key) DO UPDATE SET value = excluded.value"
)

#: One commit of one logger: (changes, clock offset, record changes, host time seen).
_Commit = tuple[dict[str, str | None], float | None, RecordChanges | None, float | None]


class FleetDatabase:
    """The shared connection and the commits waiting for the end of the turn."""

    def __init__(
        self, path: Path | str, schedule_flush: Callable[[Callable[[], None]], None]
    ) -> None:
        """``schedule_flush(callback)``: call ``callback`` once at the end of this turn
        (``loop.call_soon`` in the wiring; tests may call it at once)."""
        self.path = path
        self.conn = open_database(path)
        self.conn.executescript(SCHEMA)
        self._schedule = schedule_flush
        self._waiting: list[tuple[str, _Commit]] = []
        self.transactions = 0  # transactions written (for benchmarks and tests)

    def store(self, logger: str) -> FleetNvStore:
        return FleetNvStore(self, logger)

    def defer(self, logger: str, commit: _Commit) -> None:
        if not self._waiting:
            self._schedule(self.flush)
        self._waiting.append((logger, commit))

    def flush(self) -> None:
        """Write every waiting commit in one transaction."""
        self.write([])

    def write(self, commits: list[tuple[str, _Commit]]) -> None:
        """Write what waits and ``commits`` in one durable transaction."""
        batch, self._waiting = [*self._waiting, *commits], []
        if not batch:
            return
        conn = self.conn
        conn.execute("BEGIN IMMEDIATE")
        try:
            for logger, commit in batch:
                _apply(conn, logger, *commit)
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        conn.execute("COMMIT")
        self.transactions += 1

    def close(self) -> None:
        self.flush()
        self.conn.close()


def _apply(
    conn: sqlite3.Connection,
    logger: str,
    changes: dict[str, str | None],
    clock_offset: float | None,
    record: RecordChanges | None,
    seen: float | None,
) -> None:
    for key, value in changes.items():
        if value is None:
            conn.execute("DELETE FROM param WHERE logger = ? AND key = ?", (logger, key))
        else:
            conn.execute(
                "INSERT INTO param (logger, key, value) VALUES (?, ?, ?) "
                "ON CONFLICT(logger, key) DO UPDATE SET value = excluded.value",
                (logger, key, value),
            )
    if clock_offset is not None:
        conn.execute(_UPSERT_META, (logger, "clock_offset", repr(clock_offset)))
    if seen is not None:
        conn.execute(_UPSERT_META, (logger, "host_seen", repr(seen)))
    if record is not None:
        conn.execute("DELETE FROM record WHERE logger = ? AND seq < ?", (logger, record.head_seq))
        conn.executemany(
            "INSERT OR REPLACE INTO record (logger, seq, row) VALUES (?, ?, ?)",
            [(logger, seq, row) for seq, row in record.rows],
        )
        conn.execute(_UPSERT_META, (logger, "record_head", str(record.head_seq)))
        conn.execute(_UPSERT_META, (logger, "record_wrapped", "1" if record.wrapped else "0"))
        conn.execute(_UPSERT_META, (logger, "record_refused", "1" if record.refused else "0"))


class FleetNvStore:
    """The non-volatile memory of one module of a fleet (the engine's ``NvStore``)."""

    def __init__(self, database: FleetDatabase, logger: str) -> None:
        self.database = database
        self.logger = logger

    @property
    def conn(self) -> sqlite3.Connection:
        return self.database.conn

    def _meta(self, key: str) -> str | None:
        row = self.conn.execute(
            "SELECT value FROM meta WHERE logger = ? AND key = ?", (self.logger, key)
        ).fetchone()
        return None if row is None else str(row[0])

    def load(self) -> tuple[dict[str, str], float | None]:
        values = dict(
            self.conn.execute(
                "SELECT key, value FROM param WHERE logger = ?", (self.logger,)
            ).fetchall()
        )
        offset = self._meta("clock_offset")
        return values, (float(offset) if offset is not None else None)

    def last_seen(self) -> float | None:
        seen = self._meta("host_seen")
        return None if seen is None else float(seen)

    def load_record(self) -> tuple[list[str], int, bool, bool]:
        rows = self.conn.execute(
            "SELECT seq, row FROM record WHERE logger = ? ORDER BY seq", (self.logger,)
        ).fetchall()
        head = self._meta("record_head")
        first = rows[0][0] if rows else int(head or 0)
        return (
            [r[1] for r in rows],
            first,
            self._meta("record_wrapped") == "1",
            self._meta("record_refused") == "1",
        )

    def load_files(self) -> dict[str, bytes]:
        return {
            a: bytes(d)
            for a, d in self.conn.execute(
                "SELECT area, data FROM file WHERE logger = ?", (self.logger,)
            )
        }

    def write_file(self, area: str, data: bytes) -> None:
        self.database.flush()
        self.conn.execute(
            "INSERT INTO file (logger, area, data) VALUES (?, ?, ?) "
            "ON CONFLICT(logger, area) DO UPDATE SET data = excluded.data",
            (self.logger, area, data),
        )

    def commit(
        self,
        changes: dict[str, str | None],
        clock_offset: float | None,
        record: RecordChanges | None = None,
        seen: float | None = None,
    ) -> None:
        """A command line's changes: durable when this returns (with all that waited)."""
        self.database.write([(self.logger, (dict(changes), clock_offset, record, seen))])

    def commit_scheduled(self, record: RecordChanges, seen: float) -> None:
        """Rows the module sampled on its own: durable at the end of the turn (group
        commit across the fleet)."""
        self.database.defer(self.logger, ({}, None, record, seen))

    def close(self) -> None:
        """The database is the fleet's: :meth:`FleetDatabase.close` closes it."""

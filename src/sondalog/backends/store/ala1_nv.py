"""SQLite non-volatile memory of an ALA1 module (DESIGN.md point 5).

One database file per instance, in WAL mode with ``synchronous=FULL``: a commit returns only
when it is on disk, so a parameter is durable before its ``OK`` is sent, a record row is
durable once written, and a kill -9 at any moment leaves either a whole line (or a whole
group of sampled rows) applied or none of it.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

from sondalog.ala1.record import RecordChanges
from sondalog.io.private import connect_private

SCHEMA = """
CREATE TABLE IF NOT EXISTS param (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS record (seq INTEGER PRIMARY KEY, row TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS file (area TEXT PRIMARY KEY, data BLOB NOT NULL);
"""

_UPSERT_META = (
    "INSERT INTO meta (key, value) VALUES (?, ?) "
    "ON CONFLICT(key) DO UPDATE SET value = excluded.value"
)


def open_database(path: Path | str) -> sqlite3.Connection:
    """Open (creating if needed) a state database with the durability settings we rely on.

    The file (and its ``-wal`` and ``-shm``) is private, 0600 (docs/security.md): it holds
    the module's ``i address`` and mail ``user:password``."""
    conn = connect_private(path, check_same_thread=False)
    if str(path) != ":memory:":
        conn.execute("PRAGMA journal_mode=WAL")
    conn.execute("PRAGMA synchronous=FULL")
    return conn


class SqliteNvStore:
    """Parameters, clock, record and table files of one ALA1 module in SQLite."""

    def __init__(self, path: Path | str) -> None:
        self.path = path
        self.conn = open_database(path)
        self.conn.executescript(SCHEMA)

    def load(self) -> tuple[dict[str, str], float | None]:
        values = dict(self.conn.execute("SELECT key, value FROM param").fetchall())
        offset = self._meta("clock_offset")
        return values, (float(offset) if offset is not None else None)

    def last_seen(self) -> float | None:
        """The latest host time of any commit (to keep the module clock monotonic)."""
        seen = self._meta("host_seen")
        return None if seen is None else float(seen)

    def _meta(self, key: str) -> str | None:
        row = self.conn.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        return None if row is None else str(row[0])

    def load_record(self) -> tuple[list[str], int, bool, bool]:
        """Rows oldest first, the sequence number of the first, and the wrapped/refused flags."""
        rows = self.conn.execute("SELECT seq, row FROM record ORDER BY seq").fetchall()
        head = self._meta("record_head")
        first = rows[0][0] if rows else int(head or 0)
        return (
            [r[1] for r in rows],
            first,
            self._meta("record_wrapped") == "1",
            self._meta("record_refused") == "1",
        )

    def load_files(self) -> dict[str, bytes]:
        return {a: bytes(d) for a, d in self.conn.execute("SELECT area, data FROM file")}

    def write_file(self, area: str, data: bytes) -> None:
        """Replace a file area (``list``, ``data``) durably (§6.16)."""
        self.conn.execute(
            "INSERT INTO file (area, data) VALUES (?, ?) "
            "ON CONFLICT(area) DO UPDATE SET data = excluded.data",
            (area, data),
        )

    def commit(
        self,
        changes: dict[str, str | None],
        clock_offset: float | None,
        record: RecordChanges | None = None,
        seen: float | None = None,
    ) -> None:
        conn = self.conn
        conn.execute("BEGIN IMMEDIATE")
        try:
            for key, value in changes.items():
                if value is None:
                    conn.execute("DELETE FROM param WHERE key = ?", (key,))
                else:
                    conn.execute(
                        "INSERT INTO param (key, value) VALUES (?, ?) "
                        "ON CONFLICT(key) DO UPDATE SET value = excluded.value",
                        (key, value),
                    )
            if clock_offset is not None:
                conn.execute(_UPSERT_META, ("clock_offset", repr(clock_offset)))
            if seen is not None:
                conn.execute(_UPSERT_META, ("host_seen", repr(seen)))
            if record is not None:
                conn.execute("DELETE FROM record WHERE seq < ?", (record.head_seq,))
                conn.executemany(
                    "INSERT OR REPLACE INTO record (seq, row) VALUES (?, ?)", record.rows
                )
                conn.execute(_UPSERT_META, ("record_head", str(record.head_seq)))
                conn.execute(_UPSERT_META, ("record_wrapped", "1" if record.wrapped else "0"))
                conn.execute(_UPSERT_META, ("record_refused", "1" if record.refused else "0"))
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        conn.execute("COMMIT")

    def close(self) -> None:
        self.conn.close()

"""SQLite non-volatile memory of an ALA1 module (DESIGN.md point 5).

One database file per instance, in WAL mode with ``synchronous=FULL``: a commit returns only
when it is on disk, so a parameter is durable before its ``OK`` is sent, and a kill -9 at any
moment leaves either the whole line applied or none of it.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

SCHEMA = """
CREATE TABLE IF NOT EXISTS param (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""


def open_database(path: Path | str) -> sqlite3.Connection:
    """Open (creating if needed) a state database with the durability settings we rely on."""
    conn = sqlite3.connect(str(path), isolation_level=None, check_same_thread=False)
    if str(path) != ":memory:":
        conn.execute("PRAGMA journal_mode=WAL")
    conn.execute("PRAGMA synchronous=FULL")
    return conn


class SqliteNvStore:
    """Parameters and clock of one ALA1 module in SQLite."""

    def __init__(self, path: Path | str) -> None:
        self.path = path
        self.conn = open_database(path)
        self.conn.executescript(SCHEMA)

    def load(self) -> tuple[dict[str, str], float | None]:
        values = dict(self.conn.execute("SELECT key, value FROM param").fetchall())
        row = self.conn.execute("SELECT value FROM meta WHERE key = 'clock_offset'").fetchone()
        return values, (float(row[0]) if row else None)

    def commit(
        self, changes: dict[str, str | None], clock_offset: float | None, clear_record: bool
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
                conn.execute(
                    "INSERT INTO meta (key, value) VALUES ('clock_offset', ?) "
                    "ON CONFLICT(key) DO UPDATE SET value = excluded.value",
                    (repr(clock_offset),),
                )
            # clear_record: the record memory arrives with the sampling issue; nothing to erase.
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        conn.execute("COMMIT")

    def close(self) -> None:
        self.conn.close()

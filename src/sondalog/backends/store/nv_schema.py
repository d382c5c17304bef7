"""The tables of the ALA1 modules' SQLite memory, keyed by logger (issue 25), and the
migration of older files (:mod:`sondalog.backends.store.ala1_nv` opens them)."""

from __future__ import annotations

import sqlite3

from sondalog.backends.store import record_pages

#: The key of a logger alone in its file (``ala1.sqlite``).
SINGLE = ""

_TABLES = (
    "CREATE TABLE IF NOT EXISTS param (logger TEXT NOT NULL, key TEXT NOT NULL, "
    "value TEXT NOT NULL, PRIMARY KEY (logger, key))",
    "CREATE TABLE IF NOT EXISTS meta (logger TEXT NOT NULL, key TEXT NOT NULL, "
    "value TEXT NOT NULL, PRIMARY KEY (logger, key))",
    record_pages.TABLE,
    "CREATE TABLE IF NOT EXISTS file (logger TEXT NOT NULL, area TEXT NOT NULL, "
    "data BLOB NOT NULL, PRIMARY KEY (logger, area))",
)

#: The columns of each table in the single-logger schema before issue 25.
_OLD_COLUMNS = {
    "param": "key, value",
    "meta": "key, value",
    "record": "seq, row",
    "file": "area, data",
}


def prepare_schema(conn: sqlite3.Connection) -> None:
    """Create the keyed tables, migrating a single-logger file of the old schema and a
    record of a row a database row into pages, in one transaction (a kill -9 leaves the
    old file or the migrated one)."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        old = [
            table
            for table in _OLD_COLUMNS
            if table in tables
            and "logger" not in {c[1] for c in conn.execute(f"PRAGMA table_info({table})")}
        ]
        for table in old:
            conn.execute(f"ALTER TABLE {table} RENAME TO old_{table}")
        for statement in _TABLES:
            conn.execute(statement)
        for table in old:
            if table == "record":
                record_pages.migrate_rows(conn, "old_record", SINGLE)
            else:
                columns = _OLD_COLUMNS[table]
                conn.execute(
                    f"INSERT INTO {table} (logger, {columns}) SELECT ?, {columns} FROM old_{table}",
                    (SINGLE,),
                )
            conn.execute(f"DROP TABLE old_{table}")
        if "record" in tables and "record" not in old:  # keyed rows, before issue 23
            record_pages.migrate_rows(conn, "record")
            conn.execute("DROP TABLE record")
        conn.execute(record_pages.VIEW)
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")

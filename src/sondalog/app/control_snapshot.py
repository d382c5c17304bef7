"""A logger's whole non-volatile state, read out and written back (issue 23).

:func:`read_state` copies what one logger's memory holds in its state database
(:mod:`sondalog.backends.store.ala1_nv`: parameters, the clock offset and record pointers,
the record rows, the table files) under its key; :func:`write_state` replaces that logger's
memory with such a copy in one durable transaction (a kill -9 leaves the old memory or the
new one, never a mix). The control API's snapshot and restore use them; the engine is then
restarted from the memory (:mod:`sondalog.app.control_logger`).

A restore writes only the record rows that differ: the rows added since the snapshot go, the
rows dropped since (a cyclic record that wrapped, a ``clear``) come back. Resetting a logger
between tests is then a few rows, not a whole record.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass

from sondalog.backends.store.ala1_nv import LoggerNvStore


@dataclass(frozen=True, slots=True)
class StoredState:
    """One logger's memory: ``param`` and ``meta`` rows, record rows by sequence, files."""

    params: tuple[tuple[str, str], ...]
    meta: tuple[tuple[str, str], ...]
    record: tuple[tuple[int, str], ...]
    files: tuple[tuple[str, bytes], ...]

    @property
    def rows(self) -> int:
        return len(self.record)


def read_state(store: LoggerNvStore) -> StoredState:
    """The memory of ``store``'s logger (its waiting commits written first)."""
    store.database.flush()
    conn, key = store.conn, store.logger
    conn.execute("BEGIN")  # one consistent read
    try:
        params = conn.execute("SELECT key, value FROM param WHERE logger = ?", (key,)).fetchall()
        meta = conn.execute("SELECT key, value FROM meta WHERE logger = ?", (key,)).fetchall()
        record = conn.execute(
            "SELECT seq, row FROM record WHERE logger = ? ORDER BY seq", (key,)
        ).fetchall()
        files = conn.execute("SELECT area, data FROM file WHERE logger = ?", (key,)).fetchall()
    finally:
        conn.execute("COMMIT")
    return StoredState(
        tuple(params), tuple(meta), tuple(record), tuple((a, bytes(d)) for a, d in files)
    )


def write_state(store: LoggerNvStore, state: StoredState) -> None:
    """Make ``store``'s logger hold exactly ``state``, in one durable transaction."""
    store.database.flush()
    conn, key = store.conn, store.logger
    conn.execute("BEGIN IMMEDIATE")
    try:
        for table in ("param", "meta", "file"):
            conn.execute(f"DELETE FROM {table} WHERE logger = ?", (key,))
        conn.executemany(
            "INSERT INTO param (logger, key, value) VALUES (?, ?, ?)",
            [(key, k, v) for k, v in state.params],
        )
        conn.executemany(
            "INSERT INTO meta (logger, key, value) VALUES (?, ?, ?)",
            [(key, k, v) for k, v in state.meta],
        )
        conn.executemany(
            "INSERT INTO file (logger, area, data) VALUES (?, ?, ?)",
            [(key, a, d) for a, d in state.files],
        )
        _write_record(conn, key, state.record)
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


def _write_record(conn: sqlite3.Connection, key: str, rows: tuple[tuple[int, str], ...]) -> None:
    """The record rows of ``key`` become ``rows``: only the rows that differ are written."""
    present = set(conn.execute("SELECT seq, row FROM record WHERE logger = ?", (key,)))
    wanted = set(rows)
    gone = [(key, seq) for seq, row in present - wanted]
    conn.executemany("DELETE FROM record WHERE logger = ? AND seq = ?", gone)
    conn.executemany(
        "INSERT INTO record (logger, seq, row) VALUES (?, ?, ?)",
        [(key, seq, row) for seq, row in wanted - present],
    )

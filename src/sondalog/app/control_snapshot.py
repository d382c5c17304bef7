"""A logger's whole non-volatile state, read out and written back (issue 23).

:func:`read_state` copies what one logger's memory holds (:mod:`sondalog.backends.store.ala1_nv`:
parameters, the clock offset and record pointers, the table files, the record rows) under its
key; :func:`write_state` makes that logger's memory hold such a copy again, in one durable
transaction (a kill -9 leaves the old memory or the new one, never a mix). The control API's
snapshot and restore use them; the engine is then restarted on the restored memory
(:class:`Preloaded`: it starts from the copy just written instead of reading it back).

The record can be a megabyte of rows, so both work from the engine's own copy of it (its
rows in RAM, the same as on disk once the store has flushed) and a restore writes only the
rows that differ: the rows added since the snapshot go, the rows dropped since (a cyclic
record that wrapped, a ``clear``) come back. Resetting a logger between tests is then a few
hundred rows, not a whole record.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Sequence
from dataclasses import dataclass

from sondalog.ala1.record import RecordChanges, RecordMemory
from sondalog.backends.store.ala1_nv import LoggerNvStore


@dataclass(frozen=True, slots=True)
class StoredState:
    """One logger's memory: ``param`` and ``meta`` rows, files, the record from its first
    sequence number."""

    params: tuple[tuple[str, str], ...]
    meta: tuple[tuple[str, str], ...]
    files: tuple[tuple[str, bytes], ...]
    first_seq: int
    record: tuple[str, ...]

    @property
    def rows(self) -> int:
        return len(self.record)


def first_seq(store: LoggerNvStore) -> int:
    """The sequence number of the oldest record row on disk (of the next one when empty)."""
    row = store.conn.execute(
        "SELECT min(seq) FROM record WHERE logger = ?", (store.logger,)
    ).fetchone()
    if row is not None and row[0] is not None:
        return int(row[0])
    head = store.conn.execute(
        "SELECT value FROM meta WHERE logger = ? AND key = 'record_head'", (store.logger,)
    ).fetchone()
    return int(head[0]) if head is not None else 0


def read_state(store: LoggerNvStore, record: RecordMemory) -> StoredState:
    """The memory of ``store``'s logger, its record rows from ``record`` (the engine's)."""
    store.database.flush()  # (what waits for the group commit is on disk, as in RAM)
    conn, key = store.conn, store.logger
    params = conn.execute("SELECT key, value FROM param WHERE logger = ?", (key,)).fetchall()
    meta = conn.execute("SELECT key, value FROM meta WHERE logger = ?", (key,)).fetchall()
    files = conn.execute("SELECT area, data FROM file WHERE logger = ?", (key,)).fetchall()
    return StoredState(
        tuple(params),
        tuple(meta),
        tuple((a, bytes(d)) for a, d in files),
        first_seq(store),
        tuple(record.rows()),
    )


def write_state(store: LoggerNvStore, state: StoredState, record: RecordMemory) -> None:
    """Make ``store``'s logger hold exactly ``state``, in one durable transaction;
    ``record`` is the engine's record, the same rows as on disk."""
    store.database.flush()
    conn, key = store.conn, store.logger
    now_first, now_rows = first_seq(store), record.rows()
    conn.execute("BEGIN IMMEDIATE")
    try:
        for table, rows in (("param", state.params), ("meta", state.meta)):
            present = conn.execute(f"SELECT key, value FROM {table} WHERE logger = ?", (key,))
            if set(present) != set(rows):  # (the parameters are often as they were)
                conn.execute(f"DELETE FROM {table} WHERE logger = ?", (key,))
                conn.executemany(
                    f"INSERT INTO {table} (logger, key, value) VALUES (?, ?, ?)",
                    [(key, k, v) for k, v in rows],
                )
        conn.execute("DELETE FROM file WHERE logger = ?", (key,))
        conn.executemany(
            "INSERT INTO file (logger, area, data) VALUES (?, ?, ?)",
            [(key, a, d) for a, d in state.files],
        )
        _write_record(conn, key, now_first, now_rows, state)
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


def _write_record(
    conn: sqlite3.Connection, key: str, now_first: int, now: list[str], state: StoredState
) -> None:
    """The record rows on disk (``now`` from ``now_first``) become the state's: the rows
    beyond its range go, the rows that differ or are missing are written."""
    want, first = state.record, state.first_seq
    last = first + len(want) - 1
    if not want:
        conn.execute("DELETE FROM record WHERE logger = ?", (key,))
        return
    # two ranges of the primary key (one condition with OR would scan every row)
    conn.execute("DELETE FROM record WHERE logger = ? AND seq < ?", (key, first))
    conn.execute("DELETE FROM record WHERE logger = ? AND seq > ?", (key, last))
    low, high = max(first, now_first), min(last, now_first + len(now) - 1)
    writes: list[tuple[str, int, str]] = []
    if low <= high:  # both hold rows low..high: write those that differ (a list compare)
        mine = now[low - now_first : high - now_first + 1]
        kept = want[low - first : high - first + 1]
        if mine != list(kept):
            writes += [
                (key, seq, row)
                for seq, (old, row) in enumerate(zip(mine, kept, strict=True), low)
                if old != row
            ]
        _write_run(conn, key, first, want[: low - first])
        _write_run(conn, key, high + 1, want[high + 1 - first :])
    else:
        _write_run(conn, key, first, want)
    conn.executemany("INSERT OR REPLACE INTO record (logger, seq, row) VALUES (?, ?, ?)", writes)


def _write_run(conn: sqlite3.Connection, key: str, first: int, rows: Sequence[str]) -> None:
    """Rows ``first``, ``first + 1``, ... in one statement: SQLite reads them from one JSON
    array (``json_each``), about three times faster than a statement per row, which is
    most of a restore that rewrites a whole record (docs/control.md "Figures")."""
    if len(rows) < 64:
        conn.executemany(
            "INSERT OR REPLACE INTO record (logger, seq, row) VALUES (?, ?, ?)",
            [(key, first + i, row) for i, row in enumerate(rows)],
        )
        return
    conn.execute(
        "INSERT OR REPLACE INTO record (logger, seq, row) "
        "SELECT ?, ? + CAST(key AS INTEGER), value FROM json_each(?)",
        (key, first, json.dumps(list(rows), ensure_ascii=True, separators=(",", ":"))),
    )


class Preloaded:
    """The store of a logger whose memory was just restored to ``state``: the new engine's
    loads at start come from ``state`` (what was just written, not read back), everything
    else goes to ``store``. Once the engine is built it is given ``store`` itself."""

    def __init__(self, store: LoggerNvStore, state: StoredState) -> None:
        self.store = store
        self.state = state
        self._meta = dict(state.meta)

    def load(self) -> tuple[dict[str, str], float | None]:
        offset = self._meta.get("clock_offset")
        return dict(self.state.params), float(offset) if offset is not None else None

    def last_seen(self) -> float | None:
        seen = self._meta.get("host_seen")
        return float(seen) if seen is not None else None

    def load_record(self) -> tuple[list[str], int, bool, bool]:
        meta = self._meta
        first = self.state.first_seq
        wrapped, refused = meta.get("record_wrapped") == "1", meta.get("record_refused") == "1"
        return list(self.state.record), first, wrapped, refused

    def load_files(self) -> dict[str, bytes]:
        return dict(self.state.files)

    def write_file(self, area: str, data: bytes) -> None:
        self.store.write_file(area, data)

    def commit(
        self,
        changes: dict[str, str | None],
        clock_offset: float | None,
        record: RecordChanges | None = None,
        seen: float | None = None,
    ) -> None:
        self.store.commit(changes, clock_offset, record, seen)

    def commit_scheduled(self, record: RecordChanges, seen: float) -> None:
        self.store.commit_scheduled(record, seen)

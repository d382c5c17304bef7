"""A logger's whole non-volatile state, read out and written back (issue 23).

:func:`read_state` copies what one logger's memory holds (:mod:`sondalog.backends.store.ala1_nv`:
parameters, the clock offset and record pointers, the table files, the record rows) under its
key; :func:`write_state` makes that logger's memory hold such a copy again, in one durable
transaction (a kill -9 leaves the old memory or the new one, never a mix). The control API's
snapshot and restore use them; the engine is then restarted on the restored memory
(:class:`Preloaded`: it starts from the copy just written instead of reading it back).

The record can be a megabyte of rows, so both work from the engine's own copy of it (its
rows in RAM, the same as on disk once the store has flushed) and a restore writes only the
pages of rows that differ (:func:`sondalog.backends.store.record_pages.write_record`): the
rows added since the snapshot go, the rows dropped since (a cyclic record that wrapped, a
``clear``) come back. Resetting a logger between tests is a dozen pages; putting back a whole
record that was rewritten since, some 600 pages, not 40,000 rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from sondalog.ala1.record import RecordChanges, RecordMemory, Sealed
from sondalog.backends.store.ala1_nv import LoggerNvStore
from sondalog.backends.store.record_pages import MadePages, write_record


@dataclass(frozen=True, slots=True)
class StoredState:
    """One logger's memory: ``param`` and ``meta`` rows, files, the record from its first
    sequence number (``record_head`` in ``meta``); ``pages``: the record's pages as written
    to disk, kept from one restore to the next (a test suite restores one snapshot again
    and again)."""

    params: tuple[tuple[str, str], ...]
    meta: tuple[tuple[str, str], ...]
    files: tuple[tuple[str, bytes], ...]
    first_seq: int
    record: tuple[str, ...]
    pages: MadePages = field(default_factory=MadePages, compare=False, repr=False)
    #: The record as the engine's RAM held it (its sealed pages shared): a restore's engine
    #: starts from it instead of sealing 40,000 rows again.
    sealed: Sealed | None = field(default=None, compare=False, repr=False)

    @property
    def rows(self) -> int:
        return len(self.record)


def first_seq(record: RecordMemory) -> int:
    """The sequence number of the oldest row in ``record`` (of the next one when empty)."""
    return record.next_seq - len(record)


def read_state(store: LoggerNvStore, record: RecordMemory) -> StoredState:
    """The memory of ``store``'s logger, its record rows from ``record`` (the engine's)."""
    store.database.flush()  # (what waits for the group commit is on disk, as in RAM)
    conn, key = store.conn, store.logger
    params = conn.execute("SELECT key, value FROM param WHERE logger = ?", (key,)).fetchall()
    meta = dict(conn.execute("SELECT key, value FROM meta WHERE logger = ?", (key,)).fetchall())
    meta["record_head"] = str(first_seq(record))  # (the engine's, written or not)
    meta["record_size"] = f"{first_seq(record)},{record.next_seq},{record.chars}"
    files = conn.execute("SELECT area, data FROM file WHERE logger = ?", (key,)).fetchall()
    return StoredState(
        tuple(params),
        tuple(meta.items()),
        tuple((a, bytes(d)) for a, d in files),
        first_seq(record),
        tuple(record.rows()),
        sealed=None if record.paged else record.sealed(),  # (paged: the restore reads)
    )


def write_state(store: LoggerNvStore, state: StoredState, record: RecordMemory) -> None:
    """Make ``store``'s logger hold exactly ``state``, in one durable transaction;
    ``record`` is the engine's record, the same rows as on disk."""
    store.database.flush()
    conn, key = store.conn, store.logger
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
        now_first = first_seq(record)  # (the rows now are read only if some may be kept)
        apart = (
            now_first >= state.first_seq + state.rows or now_first + len(record) <= state.first_seq
        )
        now = () if apart else record.rows()
        write_record(conn, key, state.first_seq, state.record, now_first, now, state.pages)
    except BaseException:
        conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


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

    def load_record(self) -> tuple[list[str] | Sealed, int, bool, bool]:
        meta = self._meta
        first = self.state.first_seq
        wrapped, refused = meta.get("record_wrapped") == "1", meta.get("record_refused") == "1"
        rows = self.state.sealed or list(self.state.record)
        return rows, first, wrapped, refused

    def load_paged_record(self) -> tuple[Sealed, int, bool, bool]:
        """As :meth:`load_record`, the pages in RAM let go once built: they were just
        written, ``store`` loads them when read (issue 24)."""
        if self.state.sealed is None:  # (the engine was paged: its newest page, its size)
            return self.store.load_paged_record()
        rows, first, wrapped, refused = self.load_record()
        if isinstance(rows, Sealed):
            return replace(rows, source=self.store), first, wrapped, refused
        return Sealed((), tuple(rows), 0, self.store), first, wrapped, refused

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

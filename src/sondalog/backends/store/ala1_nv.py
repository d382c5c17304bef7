"""SQLite non-volatile memory of ALA1 modules, keyed by logger (DESIGN.md point 5; issue 25).

One implementation for a single logger (``ala1.sqlite``, one key) and a fleet
(``fleet.sqlite``, one key per serial number, issue 11): every table carries the logger's key,
and one :class:`NvDatabase` connection serves every logger of the file. The file is in WAL
mode with ``synchronous=FULL``: a commit returns only when it is on disk, so a parameter is
durable before its ``OK`` is sent, a record row is durable once written, and a kill -9 at any
moment leaves either a whole line (or a whole group of sampled rows) applied or none of it.

Group commit is a capability of the database, reached through the engine's
:class:`~sondalog.ala1.state.NvStore` (:meth:`LoggerNvStore.commit_scheduled`):

- with a ``schedule_flush`` (a fleet on an event loop), the rows a module samples on its own
  wait in memory until the end of the event-loop turn, when :meth:`NvDatabase.flush` writes
  the rows of every logger in **one transaction** (this module has no event loop);
- without one (a single logger), they are written at once;
- anything a command line commits (:meth:`LoggerNvStore.commit`) is written at once, in one
  transaction together with whatever waits, so it is durable before the line's ``OK`` and
  never overtakes earlier rows.

The record is kept in pages of rows (:mod:`sondalog.backends.store.record_pages`, issue 23).
A file made before issue 25 by the single logger (tables without the ``logger`` column) is
migrated on open, in one transaction, its rows under the key :data:`SINGLE`; so is a file
whose record is a row a database row (before issue 23).
"""

from __future__ import annotations

import contextlib
import logging
import sqlite3
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

from sondalog.ala1.record import RecordChanges, Sealed
from sondalog.backends.store import record_pages
from sondalog.backends.store.nv_schema import SINGLE as SINGLE
from sondalog.backends.store.nv_schema import prepare_schema
from sondalog.backends.store.preload import Preloaded
from sondalog.io.private import connect_private

log = logging.getLogger(__name__)


_UPSERT_META = (
    "INSERT INTO meta (logger, key, value) VALUES (?, ?, ?) "
    "ON CONFLICT(logger, key) DO UPDATE SET value = excluded.value"
)

#: One commit of one logger: (changes, clock offset, record changes, host time seen).
_Commit = tuple[dict[str, str | None], float | None, RecordChanges | None, float | None]


def open_database(path: Path | str) -> sqlite3.Connection:
    """Open (creating if needed) a state database with the durability settings we rely on.

    The file (and its ``-wal`` and ``-shm``) is private, 0600 (docs/security.md): it holds
    the module's ``i address`` and mail ``user:password``. The connection is in autocommit
    mode: every transaction here is explicit (``BEGIN IMMEDIATE`` … ``COMMIT``)."""
    conn = connect_private(path, check_same_thread=False)
    if str(path) != ":memory:":
        conn.execute("PRAGMA journal_mode=WAL")
    conn.execute("PRAGMA synchronous=FULL")
    return conn


class NvDatabase:
    """One state file: the connection shared by its loggers and the commits waiting for the
    end of the turn."""

    def __init__(
        self,
        path: Path | str,
        schedule_flush: Callable[[Callable[[], None]], None] | None = None,
        *,
        checkpoint_every: float | None = None,
        background: bool = False,
    ) -> None:
        """``schedule_flush(callback)``: call ``callback`` once at the end of this turn
        (``loop.call_soon`` in a fleet's wiring; tests may collect it). None: no group
        commit, sampled rows are written at once. ``checkpoint_every``: seconds between
        two checkpoints of the WAL by a thread of its own (a fleet, issue 24); None: SQLite
        checkpoints in the commit that fills the WAL (1,000 pages), in the caller's thread.
        ``background``: a group commit is written by a thread of its own (the event loop
        never waits for its fsync, issue 24); anything else first waits for it."""
        self.path = path
        self.conn = open_database(path)
        try:
            prepare_schema(self.conn)
        except BaseException:
            self.conn.close()
            raise
        self._checkpointer: _Checkpointer | None = None
        if checkpoint_every is not None and str(path) != ":memory:":
            self.conn.execute("PRAGMA wal_autocheckpoint=0")
            self._checkpointer = _Checkpointer(path, checkpoint_every)
            self._checkpointer.start()
        self._schedule = schedule_flush
        self._waiting: list[tuple[str, _Commit]] = []
        self._lock = threading.Lock()  # guards _waiting against the writer thread
        self._writer = ThreadPoolExecutor(1, "sondalog-nv-writer") if background else None
        self._written: Future[None] | None = None  # the last group commit handed over
        self._in_batch = False  # inside batch(): its transaction is open
        self._pending: set[str] = set()  # loggers with commits in _waiting
        self._writing: set[str] = set()  # loggers in the group the writer thread writes
        self._reader: sqlite3.Connection | None = None  # (:meth:`reader`)
        self.preload: Preloaded | None = None  # (:meth:`preloaded`)
        self.transactions = 0  # transactions written (for benchmarks and tests)

    def store(self, logger: str = SINGLE) -> LoggerNvStore:
        """The memory of ``logger`` (the engine's ``NvStore``); the database stays ours."""
        return LoggerNvStore(self, logger)

    def defer(self, logger: str, commit: _Commit) -> None:
        """Write ``commit`` at the end of the turn (at once without a ``schedule_flush``)."""
        if self._schedule is None:
            self.write([(logger, commit)])
            return
        with self._lock:
            if not self._waiting:
                self._schedule(self.flush)
            self._waiting.append((logger, commit))
            self._pending.add(logger)

    def reader(self, logger: str) -> sqlite3.Connection:
        """A connection that sees every row of ``logger`` handed to this database: what
        waits with its rows is written first, a group commit with them is waited for; else
        (a page of old rows) a connection of its own reads, the writer thread writing on."""
        with self._lock:
            waiting, writing = logger in self._pending, logger in self._writing
        if waiting:
            self.write([])
        elif writing:
            self.settle()
        if self._writer is None or self._in_batch or str(self.path) == ":memory:":
            return self.conn if waiting or writing else self._settled()
        if self._reader is None:
            self._reader = open_database(self.path)
        return self._reader

    def _settled(self) -> sqlite3.Connection:
        self.settle()
        return self.conn

    def flush(self) -> None:
        """Write every waiting commit in one transaction (by the writer thread if any)."""
        if self._writer is None:
            self.write([])
        else:
            self._written = self._writer.submit(self._write_waiting)

    def _write_waiting(self) -> None:
        """The writer thread: what waits, in one transaction; a failure loses that group
        (logged), as a failed group commit in the loop did."""
        with self._lock:
            batch, self._waiting = self._waiting, []
            self._writing, self._pending = self._pending, set()
        try:
            self._transaction(batch)
        except Exception:
            log.exception("group commit of %d loggers' rows failed", len(batch))
        finally:
            with self._lock:
                self._writing = set()

    def settle(self) -> None:
        """Wait until the writer thread has written every group handed to it: the
        connection is ours alone again (before any other transaction or read)."""
        if self._written is not None:
            self._written.result()
            self._written = None

    @contextlib.contextmanager
    def batch(self) -> Iterator[None]:
        """Every commit inside is one transaction, durable when the block ends (a fleet's
        loggers starting: nothing they commit is answered before that, issue 24)."""
        self.write([])
        self.conn.execute("BEGIN IMMEDIATE")
        self._in_batch = True
        try:
            yield
            self._in_batch = False
            batch, self._waiting = self._waiting, []
            self._pending = set()
            for logger, commit in batch:
                _apply(self.conn, logger, *commit)
        except BaseException:
            self._in_batch = False
            self.conn.execute("ROLLBACK")
            raise
        self.conn.execute("COMMIT")
        self.transactions += 1

    @contextlib.contextmanager
    def preloaded(self, loggers: Sequence[str] = ()) -> Iterator[None]:
        """Inside, the stores answer from every logger's memory read at once (a fleet
        starting: :mod:`sondalog.backends.store.preload`; ``loggers``: those starting)."""
        self.write([])
        self.settle()
        self.preload = Preloaded(self.conn, loggers)
        try:
            yield
        finally:
            self.preload = None

    def write(self, commits: list[tuple[str, _Commit]]) -> None:
        """Write what waits and ``commits`` in one durable transaction."""
        if self._in_batch:  # within the batch's own transaction
            for logger, commit in commits:
                _apply(self.conn, logger, *commit)
            return
        self.settle()
        with self._lock:
            batch, self._waiting = [*self._waiting, *commits], []
            self._pending = set()
        self._transaction(batch)

    def _transaction(self, batch: list[tuple[str, _Commit]]) -> None:
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
        if self._checkpointer is not None:
            self._checkpointer.finish()
        self.write([])
        if self._writer is not None:
            self._writer.shutdown()
        if self._reader is not None:
            self._reader.close()
        self.conn.close()  # (the last connection: SQLite checkpoints the WAL)


class _Checkpointer(threading.Thread):
    """Copies the WAL back into the database file every ``every`` seconds, with its own
    connection in its own thread: a commit of the fleet never waits for a checkpoint's
    writes and fsync (SQLite releases the GIL while it works; a PASSIVE checkpoint never
    blocks the writer)."""

    def __init__(self, path: Path | str, every: float) -> None:
        super().__init__(name="sondalog-wal-checkpoint", daemon=True)
        self.path = path
        self.every = every
        self._stop_event = threading.Event()

    def run(self) -> None:
        conn = open_database(self.path)
        try:
            while not self._stop_event.wait(self.every):
                try:
                    conn.execute("PRAGMA wal_checkpoint(PASSIVE)")
                except sqlite3.Error as exc:  # tried again next time; the WAL keeps all
                    log.warning("checkpoint of %s failed: %s", self.path, exc)
        finally:
            conn.close()

    def finish(self) -> None:
        self._stop_event.set()
        self.join()


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
        record_pages.drop_below(conn, logger, record.head_seq)
        record_pages.append_rows(conn, logger, record.rows)
        conn.execute(_UPSERT_META, (logger, "record_head", str(record.head_seq)))
        conn.execute(_UPSERT_META, (logger, "record_wrapped", "1" if record.wrapped else "0"))
        conn.execute(_UPSERT_META, (logger, "record_refused", "1" if record.refused else "0"))
        size = record.size()
        if size is not None:  # (checked against the rows at start, :meth:`load_record`)
            conn.execute(_UPSERT_META, (logger, "record_size", size))


class LoggerNvStore:
    """Parameters, clock, record and table files of one ALA1 module (the engine's
    ``NvStore``), under its key in an :class:`NvDatabase`."""

    def __init__(self, database: NvDatabase, logger: str = SINGLE) -> None:
        self.database = database
        self.logger = logger

    @property
    def conn(self) -> sqlite3.Connection:
        """The connection, once no group commit is being written (reads, file areas)."""
        self.database.settle()
        return self.database.conn

    def _meta(self, key: str) -> str | None:
        if (pre := self.database.preload) is not None and pre.knows_meta(self.logger, key):
            return pre.meta_value(self.logger, key)
        row = self.conn.execute(
            "SELECT value FROM meta WHERE logger = ? AND key = ?", (self.logger, key)
        ).fetchone()
        return None if row is None else str(row[0])

    def load(self) -> tuple[dict[str, str], float | None]:
        if (pre := self.database.preload) is not None:
            values = dict(pre.params.get(self.logger, {}))
            offset = self._meta("clock_offset")
            return values, (float(offset) if offset is not None else None)
        values = dict(
            self.conn.execute(
                "SELECT key, value FROM param WHERE logger = ?", (self.logger,)
            ).fetchall()
        )
        offset = self._meta("clock_offset")
        return values, (float(offset) if offset is not None else None)

    def last_seen(self) -> float | None:
        """The latest host time of any commit (to keep the module clock monotonic)."""
        seen = self._meta("host_seen")
        return None if seen is None else float(seen)

    def load_record(self) -> tuple[list[str], int, bool, bool]:
        """Rows oldest first, the sequence number of the first, and the wrapped/refused flags."""
        head = self._meta("record_head")
        if (pre := self.database.preload) is not None and pre.no_pages(self.logger):
            return [], 0 if head is None else int(head), *self._flags()  # (as load_rows)
        rows, first = record_pages.load_rows(
            self.conn, self.logger, None if head is None else int(head)
        )
        return rows, first, *self._flags()

    def _flags(self) -> tuple[bool, bool]:
        return self._meta("record_wrapped") == "1", self._meta("record_refused") == "1"

    def load_paged_record(self) -> tuple[Sealed, int, bool, bool]:
        """The record for an engine that loads its older pages when read (:meth:`load_page`,
        issue 24): only its newest page when the store knows its size, else every row; the
        sequence number of its first row, and the wrapped/refused flags."""
        head, size = self._meta("record_head"), self._meta("record_size")
        lazy = None
        if head is not None and size is not None:
            pre = self.database.preload
            read = None if pre is None else pre.newest_page(self.logger)
            lazy = record_pages.stored_record(self.conn, self.logger, int(head), size, self, read)
        if lazy is not None:
            return lazy, int(head or 0), *self._flags()
        rows, first, wrapped, refused = self.load_record()
        return Sealed((), tuple(rows), 0, self), first, wrapped, refused

    def load_page(self, page: int) -> tuple[int, list[str]]:
        """Page ``page`` of the record (the engine's page source, :meth:`NvDatabase.reader`)."""
        return record_pages.load_page(self.database.reader(self.logger), self.logger, page)

    def load_pages(self, first: int, last: int) -> list[tuple[int, int, list[str]]]:
        """Pages ``first`` to ``last`` that exist, in one query (a whole record read)."""
        return record_pages.load_pages(self.database.reader(self.logger), self.logger, first, last)

    def load_files(self) -> dict[str, bytes]:
        if (pre := self.database.preload) is not None:
            return dict(pre.files.get(self.logger, {}))
        return {
            a: bytes(d)
            for a, d in self.conn.execute(
                "SELECT area, data FROM file WHERE logger = ?", (self.logger,)
            )
        }

    def write_file(self, area: str, data: bytes) -> None:
        """Replace a file area (``list``, ``data``) durably (§6.16), after what waits."""
        self.database.write([])  # what waits first
        if (pre := self.database.preload) is not None:
            pre.files[self.logger][area] = data
        self.conn.execute(  # autocommit: its own durable transaction
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
        if (pre := self.database.preload) is not None:
            pre.apply(self.logger, changes, clock_offset, record, seen)
        self.database.write([(self.logger, (dict(changes), clock_offset, record, seen))])

    def commit_scheduled(self, record: RecordChanges, seen: float) -> None:
        """Rows the module sampled on its own: durable at the end of the turn (group commit
        across a fleet), at once when the database has no group commit."""
        if (pre := self.database.preload) is not None:
            pre.apply(self.logger, {}, None, record, seen)
        self.database.defer(self.logger, ({}, None, record, seen))

    def close(self) -> None:
        """The database is shared: :meth:`NvDatabase.close` closes it."""


class SqliteNvStore(LoggerNvStore):
    """A single ALA1 module alone in its own file (``ala1.sqlite``): it owns its database,
    written at once (no group commit)."""

    def __init__(self, path: Path | str) -> None:
        super().__init__(NvDatabase(path), SINGLE)

    def close(self) -> None:
        self.database.close()

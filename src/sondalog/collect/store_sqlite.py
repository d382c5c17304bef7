"""The collector's SQLite store: readings, sources with their cursors, events (the schema of
:mod:`sondalog.collect.schema`).

- WAL mode, ``synchronous=NORMAL``: a crash can lose the last transactions but never
  corrupts the file; readings and the source's cursor are committed in one transaction
  (:meth:`SqliteStore.commit_chunk`), so whatever is lost is downloaded again.
- Inserts are ``INSERT OR IGNORE`` on the key ``(logger, time, counter, channel)``: a row seen
  twice (a download read again after a crash, a data message) is stored once.
- ``meta.schema_version`` tells which schema the file has; opening an older file migrates it,
  a newer one is refused.

- **Write-behind** (:attr:`SqliteStore.write_behind`, the collector's): readings, source
  state and contact events wait in memory and are committed together, one transaction per
  ``write_behind`` seconds, not three a contact; a chunk's readings and its cursor still go in
  the same transaction, so a crash loses at most those seconds of contacts, which the next
  start downloads again. Whoever uses :attr:`SqliteStore.db` (or reads events) first gets
  everything pending committed: nothing outside this class sees the store out of order.

The store is also the ``sqlite`` sink (:mod:`sondalog.collect.sink_sqlite`), so it can take
batches like any other sink. Its ``[sqlite]`` table is read by :func:`parse_store`, for the
collector's own store and the sink alike.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import sqlite3
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

from sondalog.collect import blocks_sql
from sondalog.collect.blocks_skip import SentBlocks, transaction
from sondalog.collect.model import Reading, SinkUnavailable, utc_text
from sondalog.collect.schema import (
    SCHEMA_VERSION,
    SQLITE_ADDITIVE_COLUMNS,
    SQLITE_ADDITIVE_DDL,
    SQLITE_DDL,
)
from sondalog.config import Table, of
from sondalog.io.private import connect_private, private_parents

log = logging.getLogger(__name__)

_INSERT = (
    "INSERT OR IGNORE INTO readings "
    "(logger, channel, time, counter, type, value, text, name, unit, utc) "
    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"
)
#: Migrations from version N to N + 1 (none yet: version 1 is the first).
MIGRATIONS: dict[int, tuple[str, ...]] = {}
_STATE_COLUMNS = (
    "url",
    "kind",
    "logger",
    "state",
    "last_contact",
    "last_error",
    "offset_s",
    "cursor",
    "record_fill",
    "signal",
    "credit",
)


_COLUMNS = frozenset(_STATE_COLUMNS)
_EVENT = "INSERT INTO events (time, source, kind, text) VALUES (?, ?, ?, ?)"


class StoreError(Exception):
    """The store cannot be used (not a collector store, a newer schema, unwritable)."""


def row_of(r: Reading) -> tuple[Any, ...]:
    return (
        r.logger,
        r.channel,
        r.time.isoformat(timespec="seconds"),
        r.counter,
        r.type,
        r.value,
        r.text,
        r.name,
        r.unit,
        utc_text(r.utc),
    )


_NOW: list[Any] = [-1, ""]  # the second of the last now_text() and its text


def now_text() -> str:
    """The local time to the second, ISO 8601 with its offset (worked out once a second)."""
    second = int(time.time())
    if second != _NOW[0]:
        _NOW[0], _NOW[1] = second, datetime.fromtimestamp(second).astimezone().isoformat()
    return str(_NOW[1])


class SqliteStore:
    """One SQLite file; ``readings=False`` keeps sources and events only."""

    name = "sqlite"

    def __init__(self, path: str | Path, *, readings: bool = True) -> None:
        self.path = Path(path)
        self.keep_readings = readings
        self._db: sqlite3.Connection | None = None
        #: Seconds the writes of contacts wait to be committed together (None: at once).
        self.write_behind: float | None = None
        self._readings: list[Reading] = []
        self._states: dict[str, dict[str, Any]] = {}
        self._events: list[tuple[str, str, str, str]] = []
        self._flush: asyncio.TimerHandle | None = None
        self._known: dict[str, dict[str, Any]] = {}  # sources' rows as committed or pending
        #: The finest blocks' extremes merged so far: rows that change none are not merged
        #: again (blocks_skip; None: every row is merged).
        self.sent: SentBlocks | None = SentBlocks()

    # -- the Sink protocol ------------------------------------------------------------------
    async def open(self) -> None:
        self.open_sync()

    async def write(self, batch: Sequence[Reading]) -> None:
        try:
            with self._transaction(self.db):
                self._insert(batch)
        except sqlite3.OperationalError as exc:
            raise SinkUnavailable(f"sqlite {self.path}: {exc}") from exc

    async def close(self) -> None:
        self.close_sync()

    # -- synchronous API --------------------------------------------------------------------
    @property
    def is_open(self) -> bool:
        return self._db is not None

    @property
    def db(self) -> sqlite3.Connection:
        """The connection, with every pending write committed."""
        if self._flush is not None or self._states:
            self.flush()
        return self._conn()

    def _conn(self) -> sqlite3.Connection:
        if self._db is None:
            raise StoreError("the store is not open")
        return self._db

    @property
    def pending(self) -> bool:
        return bool(self._readings or self._states or self._events)

    def flush(self) -> None:
        """Commit what waits (readings, source states, events) in one transaction; on an
        error it stays pending for the next flush and the error is raised."""
        if self._flush is not None:
            self._flush.cancel()
            self._flush = None
        if not self.pending:
            return
        db = self._conn()
        with self._transaction(db):
            if self._readings:
                self._insert(self._readings)
            groups: dict[tuple[str, ...], list[tuple[Any, ...]]] = {}  # one UPDATE a column set
            for name, state in self._states.items():  # (checked by _pend, in _known already)
                groups.setdefault(tuple(state), []).append((*state.values(), name))
            groups.pop((), None)  # a set_state of no column
            for columns, rows in groups.items():
                db.executemany(
                    f"UPDATE sources SET {' = ?, '.join(columns)} = ? WHERE name = ?", rows
                )
            if self._events:
                db.executemany(_EVENT, self._events)
        self._readings, self._states, self._events = [], {}, []

    def _flush_due(self) -> None:
        self._flush = None
        try:
            self.flush()
        except sqlite3.Error as exc:  # kept pending: the next flush tries again
            log.warning("store %s: %s; the writes wait for the next try", self.path, exc)
            self._later()

    def _later(self) -> bool:
        """Keep the writes for later (True), or False: write them now."""
        if self.write_behind is None:
            return False
        if self._flush is None:
            try:
                loop = asyncio.get_running_loop()
            except RuntimeError:
                return False
            self._flush = loop.call_later(self.write_behind, self._flush_due)
        return True

    def _pend(self, name: str, state: dict[str, Any]) -> None:
        if not _COLUMNS.issuperset(state):
            self._update(name, state)  # raises ValueError
        self._states.setdefault(name, {}).update(state)
        known = self._known.get(name)
        if known is not None:
            known.update(state)

    def open_sync(self) -> SqliteStore:
        if self._db is not None:
            return self
        try:
            private_parents(self.path)  # the store is private, 0600 (docs/security.md)
            db = connect_private(self.path, check_same_thread=False)
        except (OSError, sqlite3.Error) as exc:
            raise StoreError(f"{self.path}: cannot open: {exc}") from exc
        try:
            db.execute("PRAGMA busy_timeout=10000")
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("PRAGMA synchronous=NORMAL")
            self._migrate(db)
        except sqlite3.DatabaseError as exc:
            db.close()
            raise StoreError(f"{self.path} is not a collector store: {exc}") from exc
        except BaseException:
            db.close()
            raise
        db.isolation_level = "DEFERRED"  # `with db:` makes a transaction
        self._db = db
        return self

    def check_sync(self) -> None:
        """Raise :class:`StoreError` when an existing file could not be opened as the store
        (not a collector store, a newer schema); reads only, creates nothing."""
        if not self.path.exists():
            return
        try:
            db = sqlite3.connect(f"{self.path.resolve().as_uri()}?mode=ro", uri=True)
        except sqlite3.Error as exc:
            raise StoreError(f"{self.path}: cannot open: {exc}") from exc
        try:
            self._version(db)
        except sqlite3.DatabaseError as exc:
            raise StoreError(f"{self.path} is not a collector store: {exc}") from exc
        finally:
            db.close()

    def _version(self, db: sqlite3.Connection) -> int:
        """The file's schema version (0: empty); :class:`StoreError` if it cannot be used."""
        tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        version = 0
        if "meta" in tables:
            row = db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
            version = int(row[0]) if row else 0
        elif tables - {"sqlite_sequence"}:
            raise StoreError(f"{self.path} is not a collector store (tables {sorted(tables)})")
        if version > SCHEMA_VERSION:
            raise StoreError(
                f"{self.path} has schema version {version}; this sondalog knows up to "
                f"{SCHEMA_VERSION}: upgrade sondalog"
            )
        return version

    def _migrate(self, db: sqlite3.Connection) -> None:
        version = self._version(db)
        if version == SCHEMA_VERSION:
            db.executescript(SQLITE_ADDITIVE_DDL)
            _add_columns(db)
            return
        script = ["BEGIN IMMEDIATE;", SQLITE_DDL if version == 0 else ""]
        for step in range(max(version, 1), SCHEMA_VERSION):
            script.extend(f"{sql};" for sql in MIGRATIONS[step])
        script.extend(
            (
                "INSERT OR REPLACE INTO meta (key, value) "
                f"VALUES ('schema_version', '{SCHEMA_VERSION}');",
                SQLITE_ADDITIVE_DDL,
                "COMMIT;",
            )
        )
        try:
            db.executescript("\n".join(script))
        except BaseException:
            if db.in_transaction:
                db.execute("ROLLBACK")
            raise
        _add_columns(db)

    def close_sync(self) -> None:
        if self._db is not None:
            try:
                self.flush()
            finally:
                self._db.close()
            self._db = None

    def _transaction(self, db: sqlite3.Connection) -> contextlib.AbstractContextManager[None]:
        return transaction(db, self.sent)

    def _insert(self, batch: Sequence[Reading]) -> None:
        if self.keep_readings:
            conn = self._conn()
            done = conn.executemany(_INSERT, map(row_of, batch)).rowcount
            if self.sent is not None and done == len(batch):  # the rows that change a block
                batch = self.sent.news(batch)  # (duplicates: blocks read from stored rows)
                done = len(batch)
            blocks_sql.after_batch_sqlite(conn, batch, done)  # the dashboard's extremes

    def commit_chunk(
        self, source: str, batch: Sequence[Reading], cursor: str | None, **state: Any
    ) -> None:
        """Readings and the source's new cursor (and state columns) in one transaction."""
        if cursor is not None:
            state["cursor"] = cursor
        if self._later():
            self._pend(source, state)
            if self.keep_readings:
                self._readings += batch
            return
        with self._transaction(self._conn()):
            self._insert(batch)
            self._update(source, state)

    # -- sources and events -----------------------------------------------------------------
    def add_source(self, name: str, url: str, kind: str) -> None:
        """Register a source (kept with its cursor if it exists; the URL may change)."""
        self._known.pop(name, None)
        with self.db:
            self.db.execute(
                "INSERT INTO sources (name, url, kind) VALUES (?, ?, ?) "
                "ON CONFLICT (name) DO UPDATE SET url = excluded.url, kind = excluded.kind",
                (name, url, kind),
            )

    def source(self, name: str) -> dict[str, Any] | None:
        """The source's state columns (pending writes included); read once, then kept."""
        known = self._known.get(name)
        if known is None:
            cur = self._conn().execute(
                f"SELECT {', '.join(_STATE_COLUMNS)} FROM sources WHERE name = ?", (name,)
            )
            row = cur.fetchone()
            if row is None:
                return None
            known = dict(zip(_STATE_COLUMNS, row, strict=True))
            known.update(self._states.get(name, {}))
            self._known[name] = known
        return dict(known)

    def cursor(self, name: str) -> str | None:
        row = self.source(name)
        return None if row is None else row["cursor"]

    def set_state(self, name: str, **state: Any) -> None:
        if self._later():
            self._pend(name, state)
            return
        with self._conn():
            self._update(name, state)

    def finish(self, name: str, kind: str, text: str, **state: Any) -> None:
        """The end of a contact: the source's state and its event in one transaction."""
        if self._later():
            self._pend(name, state)
            self._events.append((now_text(), name, kind, text))
            return
        with self._conn():
            self._update(name, state)
            self._conn().execute(_EVENT, (now_text(), name, kind, text))

    def _update(self, name: str, state: dict[str, Any]) -> None:
        if not state:
            return
        unknown = set(state) - set(_STATE_COLUMNS)
        if unknown:
            raise ValueError(f"unknown source columns {sorted(unknown)}")
        known = self._known.get(name)
        if known is not None:
            known.update(state)
        assignments = ", ".join(f"{column} = ?" for column in state)
        self._conn().execute(
            f"UPDATE sources SET {assignments} WHERE name = ?", (*state.values(), name)
        )

    def set_channels(
        self,
        logger: str,
        channels: Iterable[tuple[int, str | None, str | None, int | None]],
        formats: dict[int, str] | None = None,
    ) -> None:
        """Replace ``logger``'s rows of the ``channels`` table: ``(channel, name, unit, type)``
        and the channels' value formats (§6.5.7, ``0.1``) where known."""
        formats = formats or {}
        with self.db:
            self.db.execute("DELETE FROM channels WHERE logger = ?", (logger,))
            self.db.executemany(
                "INSERT INTO channels (logger, channel, name, unit, type, format) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                [(logger, *c, formats.get(c[0])) for c in channels],
            )

    def event(self, source: str, kind: str, text: str, time: str | None = None) -> None:
        with self.db:
            self.db.execute(_EVENT, (time or now_text(), source, kind, text))

    def events(self, source: str | None = None) -> list[tuple[str, str, str, str]]:
        sql = "SELECT time, source, kind, text FROM events"
        args: tuple[Any, ...] = ()
        if source is not None:
            sql += " WHERE source = ?"
            args = (source,)
        return [tuple(r) for r in self.db.execute(sql + " ORDER BY id", args)]


@dataclass(frozen=True, slots=True)
class StoreConfig:
    """The ``[sqlite]`` table: the store's file and whether it keeps readings."""

    path: Path
    readings: bool = True


def parse_store(table: Table) -> StoreConfig:
    """The ``[sqlite]`` table: ``path`` (default ``collector.sqlite`` beside the file; a file
    name, not a directory), ``readings`` (default true)."""
    table.keys(("path", "readings"))
    path = table.path("path", "collector.sqlite")
    if path.is_dir():
        raise table.fail("path", f"{path} is a directory; name the store's file")
    return StoreConfig(path, table.flag("readings", True))


def open_store(config: StoreConfig) -> SqliteStore:
    """The store of ``config`` (not opened yet): the factory of the ``sqlite`` sink."""
    return SqliteStore(config.path, readings=config.readings)


def create(table: Mapping[str, object]) -> SqliteStore:
    """A store straight from a plain ``[sqlite]`` mapping (benchmarks); ``ConfigError``."""
    return open_store(parse_store(of(table, where="sqlite")))


def _add_columns(db: sqlite3.Connection) -> None:
    """Columns that additive tables gained later (``SQLITE_ADDITIVE_COLUMNS``)."""
    for table, column, kind in SQLITE_ADDITIVE_COLUMNS:
        have = {row[1] for row in db.execute(f"PRAGMA table_info({table})")}
        if column not in have:
            with db:
                db.execute(f"ALTER TABLE {table} ADD COLUMN {column} {kind}")

"""The collector's SQLite store: readings, sources with their cursors, events (the schema of
:mod:`sondalog.collect.schema`).

- WAL mode, ``synchronous=NORMAL``: a crash can lose the last transactions but never
  corrupts the file; readings and the source's cursor are committed in one transaction
  (:meth:`SqliteStore.commit_chunk`), so whatever is lost is downloaded again.
- Inserts are ``INSERT OR IGNORE`` on the key ``(logger, time, counter, channel)``: a row seen
  twice (a download read again after a crash, a data message) is stored once.
- ``meta.schema_version`` tells which schema the file has; opening an older file migrates it,
  a newer one is refused.

The store is also the ``sqlite`` sink (:mod:`sondalog.collect.sink_sqlite`), so it can take
batches like any other sink. Its ``[sqlite]`` table is read by :func:`parse_store`, for the
collector's own store and the sink alike.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

from sondalog.collect import blocks_sql
from sondalog.collect.model import Reading, SinkUnavailable, utc_text
from sondalog.collect.schema import (
    SCHEMA_VERSION,
    SQLITE_ADDITIVE_COLUMNS,
    SQLITE_ADDITIVE_DDL,
    SQLITE_DDL,
)
from sondalog.config import Table, of
from sondalog.io.private import connect_private, private_parents

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


def now_text() -> str:
    return datetime.now().astimezone().isoformat(timespec="seconds")


class SqliteStore:
    """One SQLite file; ``readings=False`` keeps sources and events only."""

    name = "sqlite"

    def __init__(self, path: str | Path, *, readings: bool = True) -> None:
        self.path = Path(path)
        self.keep_readings = readings
        self._db: sqlite3.Connection | None = None

    # -- the Sink protocol ------------------------------------------------------------------
    async def open(self) -> None:
        self.open_sync()

    async def write(self, batch: Sequence[Reading]) -> None:
        try:
            with self.db:
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
        if self._db is None:
            raise StoreError("the store is not open")
        return self._db

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
            self._db.close()
            self._db = None

    def _insert(self, batch: Sequence[Reading]) -> None:
        if self.keep_readings:
            done = self.db.executemany(_INSERT, [row_of(r) for r in batch]).rowcount
            blocks_sql.after_batch_sqlite(self.db, batch, done)  # the dashboard's extremes

    def commit_chunk(
        self, source: str, batch: Sequence[Reading], cursor: str | None, **state: Any
    ) -> None:
        """Readings and the source's new cursor (and state columns) in one transaction."""
        with self.db:
            self._insert(batch)
            if cursor is not None:
                state["cursor"] = cursor
            self._update(source, state)

    # -- sources and events -----------------------------------------------------------------
    def add_source(self, name: str, url: str, kind: str) -> None:
        """Register a source (kept with its cursor if it exists; the URL may change)."""
        with self.db:
            self.db.execute(
                "INSERT INTO sources (name, url, kind) VALUES (?, ?, ?) "
                "ON CONFLICT (name) DO UPDATE SET url = excluded.url, kind = excluded.kind",
                (name, url, kind),
            )

    def source(self, name: str) -> dict[str, Any] | None:
        cur = self.db.execute(
            f"SELECT {', '.join(_STATE_COLUMNS)} FROM sources WHERE name = ?", (name,)
        )
        row = cur.fetchone()
        return None if row is None else dict(zip(_STATE_COLUMNS, row, strict=True))

    def cursor(self, name: str) -> str | None:
        row = self.source(name)
        return None if row is None else row["cursor"]

    def set_state(self, name: str, **state: Any) -> None:
        with self.db:
            self._update(name, state)

    def finish(self, name: str, kind: str, text: str, **state: Any) -> None:
        """The end of a contact: the source's state and its event in one transaction."""
        with self.db:
            self._update(name, state)
            self.db.execute(
                "INSERT INTO events (time, source, kind, text) VALUES (?, ?, ?, ?)",
                (now_text(), name, kind, text),
            )

    def _update(self, name: str, state: dict[str, Any]) -> None:
        if not state:
            return
        unknown = set(state) - set(_STATE_COLUMNS)
        if unknown:
            raise ValueError(f"unknown source columns {sorted(unknown)}")
        assignments = ", ".join(f"{column} = ?" for column in state)
        self.db.execute(f"UPDATE sources SET {assignments} WHERE name = ?", (*state.values(), name))

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
            self.db.execute(
                "INSERT INTO events (time, source, kind, text) VALUES (?, ?, ?, ?)",
                (time or now_text(), source, kind, text),
            )

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

"""Where the dashboard reads the readings: the collector's SQLite file or a PostgreSQL server.

A :class:`Db` is what one request reads through: ``rows(sql, params)`` runs a reading query
written once for both (:mod:`.dialect`) on the store of record, and ``file`` is the
collector's SQLite file, which keeps what only it has (``sources``, ``events``,
``channels``: the collector always has that file, :mod:`sondalog.collect.store_sqlite`),
or None when the dashboard was given a server alone.

- :class:`Readings` ``(path, dsn=None)``: with ``dsn`` None the readings are in the file;
  :meth:`Readings.open` gives a read-only connection to it (``mode=ro``), closed after the
  request. With a ``dsn`` (``postgresql://...`` or ``key=value``) the readings are on that
  server: at most :data:`POOL` connections, kept between requests and handed to one
  request at a time, each read-only (``default_transaction_read_only``) and bounded
  (``statement_timeout`` :data:`STATEMENT_TIMEOUT_MS`).
- A server that cannot be reached raises :class:`~.store.StoreUnavailable` (503, no DSN in
  the answer: it may hold a password).
"""

from __future__ import annotations

import queue
import sqlite3
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .dialect import POSTGRES, POSTGRES_V1, SQLITE, ReadDialect

#: The most connections to a PostgreSQL server one dashboard keeps.
POOL = 4
#: Longest a reading query may run on the server (milliseconds).
STATEMENT_TIMEOUT_MS = 30_000

Row = tuple[Any, ...]


class StoreUnavailable(RuntimeError):
    """The store is missing or cannot be read (the collector has not created it yet, the
    server is down)."""


class Db:
    """One request's way to the readings (and the collector's file)."""

    def __init__(
        self, dialect: ReadDialect, conn: Any, file: sqlite3.Connection | None, has_blocks: bool
    ) -> None:
        self.dialect = dialect
        self.conn = conn
        self.file = file
        #: Whether the store has the per-block extremes (:mod:`.blocks`).
        self.has_blocks = has_blocks

    def rows(self, sql: str, params: Sequence[object] = ()) -> list[Row]:
        """The rows of a reading query written with ``?`` markers."""
        return list(self.conn.execute(self.dialect.sql(sql), tuple(params)).fetchall())

    def first(self, sql: str, params: Sequence[object] = ()) -> Row | None:
        found = self.rows(sql, params)
        return found[0] if found else None


def connect_file(path: Path) -> sqlite3.Connection:
    """A read-only connection to the collector's file at ``path``."""
    if not path.is_file():
        raise StoreUnavailable(f"the store {path} does not exist yet")
    try:
        conn = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, timeout=5.0)
        conn.execute("SELECT 1 FROM readings LIMIT 1")
    except sqlite3.Error as exc:
        raise StoreUnavailable(f"the store {path} cannot be read: {exc}") from exc
    return conn


#: Whether the store has the per-block extremes (:mod:`sondalog.collect.blocks_sql`: the
#: sinks keep them for every batch once the table is there; which loggers' are complete is
#: asked per plot, :func:`.blocks.usable`).
FILE_BLOCKS = (
    "SELECT count(*) = 2 FROM sqlite_master WHERE type = 'table' AND name IN "
    "('readings_extremes', 'readings_extremes_todo')"
)
SERVER_BLOCKS = (
    "SELECT to_regclass('readings_extremes') IS NOT NULL "
    "AND to_regclass('readings_extremes_todo') IS NOT NULL, "
    "to_regclass('record_rows') IS NOT NULL"
)
"""... and whether the server's schema is version 2 (``record_rows``; a version-1 server is
read until its collector migrates it, :mod:`sondalog.collect.schema_pg`)."""


def _file_blocks(conn: sqlite3.Connection) -> bool:
    return bool(conn.execute(FILE_BLOCKS).fetchone()[0])


class Readings:
    """The store of record of the readings: the file ``path`` or the server ``dsn``."""

    def __init__(self, path: Path | None, dsn: str | None = None, connect_timeout: int = 5):
        if path is None and dsn is None:
            raise ValueError("the readings need a store: a file or a PostgreSQL server")
        self.path = path
        self.dsn = dsn
        self.connect_timeout = connect_timeout
        self._idle: queue.LifoQueue[Any] = queue.LifoQueue()
        self._slots = threading.BoundedSemaphore(POOL)
        self._lock = threading.Lock()
        self._open: list[Any] = []

    @property
    def where(self) -> str:
        """The store in answers (never a DSN: it may hold a password)."""
        return "the [postgres] server" if self.dsn is not None else str(self.path)

    def open(self) -> Db:
        """A :class:`Db` for one request; give it back with :meth:`close`."""
        if self.dsn is None:
            assert self.path is not None
            conn = connect_file(self.path)
            return Db(SQLITE, conn, conn, _file_blocks(conn))
        file = None
        if self.path is not None and self.path.is_file():
            file = connect_file(self.path)
        try:
            conn = self._take()
            try:
                blocks, keyed = conn.execute(SERVER_BLOCKS).fetchone()
            except Exception as exc:
                self._discard(conn)
                self._slots.release()
                raise StoreUnavailable(f"the readings on {self.where}: {exc}") from exc
        except BaseException:
            if file is not None:
                file.close()
            raise
        return Db(POSTGRES if keyed else POSTGRES_V1, conn, file, bool(blocks))

    def close(self, db: Db) -> None:
        """Give back ``db`` (its server connection stays open for the next request)."""
        if db.file is not None:
            db.file.close()
        if db.dialect is SQLITE:
            return
        conn = db.conn
        if conn.closed or conn.broken or conn.info.transaction_status != 0:  # 0: idle
            self._discard(conn)
        else:
            self._idle.put(conn)
        self._slots.release()

    def shutdown(self) -> None:
        """Close every kept server connection (the dashboard stops)."""
        with self._lock:
            conns, self._open = self._open, []
        for conn in conns:
            conn.close()
        while not self._idle.empty():
            self._idle.get_nowait()

    def _take(self) -> Any:
        if not self._slots.acquire(timeout=30):
            raise StoreUnavailable(f"the readings on {self.where}: every connection is busy")
        try:
            while True:
                try:
                    conn = self._idle.get_nowait()
                except queue.Empty:
                    return self._connect()
                if not (conn.closed or conn.broken):
                    return conn
                self._discard(conn)
        except BaseException:
            self._slots.release()
            raise

    def _connect(self) -> Any:
        import psycopg

        try:
            conn = psycopg.connect(
                self.dsn or "", autocommit=True, connect_timeout=self.connect_timeout
            )
        except psycopg.Error as exc:
            raise StoreUnavailable(f"the readings on {self.where} cannot be read: {exc}") from exc
        try:
            conn.execute("SET default_transaction_read_only = on")
            conn.execute(f"SET statement_timeout = {STATEMENT_TIMEOUT_MS}")
            # short index-range queries, each costed high by the planner: compiling them
            # (JIT) took longer than running them (seconds on the year's plot)
            conn.execute("SET jit = off")
            # the tables' pages are in memory: a key range read in the key's order costs
            # the server less than its rows gathered and sorted (the year's blocks: 11 ms
            # against 22), which the default cost of a random page (4) made it choose
            conn.execute("SET random_page_cost = 1.1")
            ok = conn.execute("SELECT to_regclass('readings') IS NOT NULL").fetchone()
        except psycopg.Error as exc:
            conn.close()
            raise StoreUnavailable(f"the readings on {self.where} cannot be read: {exc}") from exc
        if not (ok and ok[0]):
            conn.close()
            raise StoreUnavailable(f"the readings on {self.where}: no readings table yet")
        with self._lock:
            self._open.append(conn)
        return conn

    def _discard(self, conn: Any) -> None:
        with self._lock:
            if conn in self._open:
                self._open.remove(conn)
        conn.close()


def query_errors() -> tuple[type[BaseException], ...]:
    """The errors a reading query may raise on either store (a lost server: 503)."""
    try:
        import psycopg
    except ImportError:  # pragma: no cover - psycopg is a dependency of the collector
        return (sqlite3.Error,)
    return (sqlite3.OperationalError, psycopg.OperationalError, psycopg.InterfaceError)

"""Alarm states, their history and the notification outbox on SQLite (issue 21).

The tables of :mod:`.schema`, in the collector's store file or one of their own (WAL,
``synchronous=NORMAL``, files 0600 like every store of sondalog). :class:`AlarmStore` is
:class:`~.store_sql.SqlAlarmStore` (every statement, written once for SQLite and
PostgreSQL) on a file: one ``sqlite3`` connection in autocommit mode, and a
:meth:`~.store_sql.SqlAlarmStore.transaction` is one ``BEGIN IMMEDIATE`` transaction, so
two processes on one file never take the same outbox row while its lease runs.

``read_only=True`` is the dashboard's way in: the file is opened read-only and nothing is
created; a file without the alarm tables raises :class:`AlarmTablesMissing` (no alarms
yet). The dashboard (``sondalog.web``) sees the alarm stores through this module only, so
it names :class:`SqlAlarmStore` from here too.
"""

from __future__ import annotations

import contextlib
import sqlite3
from collections.abc import Iterator
from pathlib import Path

from sondalog.io.private import connect_private, private_parents

from .dialect import SQLITE
from .schema import ALARM_TABLES, PROGRESS_TABLE, SQLITE_ALARM_DDL
from .store_sql import AlarmTablesMissing, SqlAlarmStore

__all__ = ["AlarmStore", "AlarmTablesMissing", "SqlAlarmStore"]


class AlarmStore(SqlAlarmStore):
    """The alarm tables in the SQLite file ``path``."""

    dialect = SQLITE
    errors = (sqlite3.Error,)

    def __init__(self, path: Path | str, *, read_only: bool = False) -> None:
        super().__init__()
        self.path = Path(path)
        self.read_only = read_only

    @property
    def where(self) -> str:
        return str(self.path)

    def _connect(self) -> sqlite3.Connection:
        if self.read_only:
            return self._connect_read_only()
        private_parents(self.path)
        db = connect_private(self.path, isolation_level=None, check_same_thread=False)
        try:
            db.execute("PRAGMA busy_timeout=10000")
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("PRAGMA synchronous=NORMAL")
            db.executescript(SQLITE_ALARM_DDL)
        except BaseException:
            db.close()
            raise
        return db

    def _connect_read_only(self) -> sqlite3.Connection:
        if not self.path.is_file():
            raise AlarmTablesMissing(f"the store {self.path} does not exist yet")
        uri = f"{self.path.resolve().as_uri()}?mode=ro"
        db = sqlite3.connect(uri, uri=True, isolation_level=None, check_same_thread=False)
        try:
            db.execute("PRAGMA busy_timeout=10000")
            rows = db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")
            tables = {str(r[0]) for r in rows}
            missing = set(ALARM_TABLES) - tables
        except BaseException:
            db.close()
            raise
        if missing:
            db.close()
            raise AlarmTablesMissing(f"the store {self.path} has no {min(missing)} table")
        self._progress_table = PROGRESS_TABLE in tables
        return db

    @contextlib.contextmanager
    def _begin(self, db: sqlite3.Connection) -> Iterator[None]:
        db.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            db.execute("ROLLBACK")
            raise
        else:
            db.execute("COMMIT")

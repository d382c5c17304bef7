"""Alarm states, their history and the notification outbox on PostgreSQL (issue 21).

:class:`PostgresAlarmStore` is :class:`~.store_sql.SqlAlarmStore` (every statement, written
once for SQLite and PostgreSQL) on the server of the ``[postgres]`` table when it says
``alarms = true`` (docs/alarms.md "On PostgreSQL"): one synchronous psycopg 3 connection in
autocommit mode; a :meth:`~.store_sql.SqlAlarmStore.transaction` is one server transaction
(nested calls join it). The tables are created on connecting, under an advisory lock (two
collectors starting together).

Several collectors may share the tables (how: :mod:`.store_sql`); claims take due rows
``FOR UPDATE SKIP LOCKED`` (:data:`~.schema.POSTGRES_CLAIM`).

A lost connection is opened again by the next call outside a transaction; the failing one
raises ``psycopg.OperationalError`` (the alarm loop logs it and tries again on its next
turn).
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from typing import Any

import psycopg

from .dialect import POSTGRES
from .schema import POSTGRES_ALARM_DDL
from .store_sql import SqlAlarmStore

#: Advisory lock of the DDL (two collectors starting together).
_DDL_LOCK = 0x50D4_A1A2

Conn = psycopg.Connection[tuple[Any, ...]]


class PostgresAlarmStore(SqlAlarmStore):
    """The alarm tables on the PostgreSQL server ``dsn``."""

    dialect = POSTGRES
    errors = (psycopg.Error,)

    def __init__(self, dsn: str, connect_timeout: int = 5) -> None:
        super().__init__()
        self.dsn = dsn
        self.connect_timeout = connect_timeout

    @property
    def where(self) -> str:
        return self.dsn

    def _connect(self) -> Conn:
        db: Conn = psycopg.connect(self.dsn, autocommit=True, connect_timeout=self.connect_timeout)
        try:
            with db.transaction():
                db.execute("SELECT pg_advisory_xact_lock(%s)", (_DDL_LOCK,))
                db.execute(POSTGRES_ALARM_DDL)
        except BaseException:
            db.close()
            raise
        return db

    def _begin(self, db: Conn) -> AbstractContextManager[object]:
        return db.transaction()

    def _alive(self, db: Conn) -> bool:
        return not (db.closed or db.broken)

"""What differs in the dashboard's reading queries between SQLite and PostgreSQL (issue 24).

The queries of :mod:`.store` and :mod:`.blocks` are written once, with ``?`` for each
parameter (as :mod:`sondalog.collect.alarms.dialect` does for the alarm store). A
:class:`ReadDialect` turns such a text into its server's and spells the few expressions that
differ:

- ``?`` becomes the driver's marker (``sqlite3``: ``?``; psycopg: ``%s``);
- a ``time`` column read back: on SQLite it is the text ``YYYY-MM-DDTHH:MM:SS`` already; on
  PostgreSQL (``timestamp``, :mod:`sondalog.collect.sink_postgres`) it is written as that
  text by ``to_char``, so every caller gets the store's one spelling
  (:mod:`sondalog.collect.schema`); ``utc`` likewise as ``2007-03-01T11:00:00Z``;
- seconds since 1970 of a ``time`` (the logger's clock read as UTC, :mod:`.times`):
  ``unixepoch`` / ``extract(epoch ...)``;
- the table keyed by ``(logger, time, counter)`` for a ``min``/``max`` over the key (a skip
  scan of the loggers): ``readings`` itself on SQLite; on PostgreSQL ``readings`` is a view
  of ``record_rows`` (schema version 2, :mod:`sondalog.collect.schema_pg`: one row a record
  row), over which the server does not look the extremes up in the index;
- the readings of a logger's time range (:meth:`ReadDialect.readings`): on PostgreSQL of
  version 2 ``record_rows`` with only the arrays a query reads unnested (the view subscripts
  each array for every reading: measured 3.5 times the time of ``unnest`` on a count of a
  year's first 13,000 readings, and 8 times with ``unnest`` in the select list).

(A bucket's extreme with the time of a reading that has it is spelt in :mod:`.blocks`:
SQLite's bare column beside a lone ``min``/``max``, PostgreSQL's ``DISTINCT ON``.)

Comparing a ``timestamp`` with a text parameter works on PostgreSQL (psycopg sends text as
``unknown``, the server casts it), so parameters are the store's texts on both.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

from sondalog.collect.schema import RECORD_ARRAYS

_TEXT_TIME = "to_char({0}, 'YYYY-MM-DD\"T\"HH24:MI:SS')"
_TEXT_UTC = "to_char({0} AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS\"Z\"')"


@dataclass(frozen=True, slots=True)
class ReadDialect:
    """One server's spelling of the dashboard's reading queries."""

    name: str
    #: The driver's parameter marker.
    mark: str
    #: The table with one row a record row, keyed by ``(logger, time, counter)``.
    keys: str = "readings"

    @property
    def postgres(self) -> bool:
        return self.name == "postgresql"

    def sql(self, text: str) -> str:
        """``text`` (``?`` markers) in this dialect."""
        return _adapt(self, text)

    def time(self, column: str) -> str:
        """``column`` (a ``time``) read back as ``YYYY-MM-DDTHH:MM:SS``."""
        return _TEXT_TIME.format(column) if self.postgres else column

    def utc(self, column: str) -> str:
        """``column`` (``utc``) read back as ``YYYY-MM-DDTHH:MM:SSZ`` (NULL stays NULL)."""
        return _TEXT_UTC.format(column) if self.postgres else column

    def readings(self, where: str, columns: str, tail: str = "") -> str:
        """A ``FROM`` item named ``readings`` of the readings whose record rows meet
        ``where`` (on ``logger``, ``time``, ``counter`` only), with ``columns`` (comma
        separated, of ``readings``'); a row's readings in channel order. ``tail`` (``ORDER
        BY`` the key's columns, ``LIMIT``) is applied inside, to the readings; conditions on
        the readings themselves (``channel > 0``) go outside, on the item's columns, and so
        does the order wanted of the result."""
        return _readings(self, where, columns, tail)

    def query(
        self,
        select: str,
        columns: str,
        where: str,
        *,
        order: str = "",
        limit: bool = False,
        positive: bool = True,
    ) -> str:
        """``SELECT select`` over the readings whose record rows meet ``where`` (on
        ``logger``, ``time``, ``counter``), with ``channel > 0`` unless not ``positive``,
        in ``order`` (of the key), at most ``?`` of them with ``limit``; ``columns`` are
        the readings' columns ``select`` uses. On a table of one row a reading (SQLite, a
        version-1 server) the plain query: SQLite compiles a subquery each time it is
        given one (a week's plot from the rows gives 1,000 texts)."""
        cut = " LIMIT ?" if limit else ""
        if self.keys == "readings":
            cond = " AND channel > 0" if positive else ""
            return f"SELECT {select} FROM readings WHERE {where}{cond} {order}{cut}"
        cond = " WHERE channel > 0" if positive else ""
        return f"SELECT {select} FROM {self.readings(where, columns, order)}{cond} {order}{cut}"

    def epoch(self, column: str) -> str:
        """Whole seconds since 1970 of ``column`` (a ``time``) read as UTC."""
        if self.postgres:
            return f"extract(epoch FROM {column})::bigint"
        return f"unixepoch({column})"


@functools.cache
def _adapt(dialect: ReadDialect, text: str) -> str:
    if "%" in text and dialect.mark == "%s":  # a literal % would be a psycopg marker
        raise ValueError(f"a literal % in SQL for {dialect.name}: {text!r}")
    return text.replace("?", dialect.mark)


@functools.cache
def _readings(dialect: ReadDialect, where: str, columns: str, tail: str) -> str:
    names = [c.strip() for c in columns.split(",")]
    if dialect.keys == "readings":  # a table of one row a reading
        return f"(SELECT {', '.join(names)} FROM readings WHERE {where} {tail}) readings"
    # set-returning functions in the select list: in step, one row each a reading, without
    # the table of results a function in FROM is put in (measured 2.5 times as fast)
    cols = ", ".join(f"unnest({c}) AS {c}" if c in RECORD_ARRAYS else c for c in names)
    return f"(SELECT {cols} FROM {dialect.keys} WHERE {where} {tail}) readings"


SQLITE = ReadDialect("sqlite", "?")
POSTGRES = ReadDialect("postgresql", "%s", "record_rows")
#: A server of schema version 1 (``readings`` a table), until its collector migrates it.
POSTGRES_V1 = ReadDialect("postgresql", "%s")

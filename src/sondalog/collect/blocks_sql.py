"""Each channel's extremes per block of time, kept by the sinks per batch (issue 24).

The dashboard's plot of a long range sends each channel's smallest and largest value per
bucket with the time of a reading that has it (:mod:`sondalog.web.series`). Read from
``readings`` that is every row of the range (a year of 12 channels at 1 minute: 6.3
million); ``readings_extremes`` keeps the same answer per fixed block of time::

    readings_extremes (
        logger  TEXT    NOT NULL,  -- as readings.logger
        size    INTEGER NOT NULL,  -- the block's length in seconds (SIZES)
        start   INTEGER NOT NULL,  -- its start: seconds since 1970 of the logger's clock read
                                   -- as UTC (as the plot's x), a multiple of size
        channel INTEGER NOT NULL,  -- > 0 (text rows have no value)
        vmin    REAL,              -- the smallest value, NULL when every value is NULL
        tmin    INTEGER NOT NULL,  -- the earliest time (seconds) with vmin; all NULL: the latest
        vmax    REAL,              -- the largest value, likewise
        tmax    INTEGER NOT NULL,
        PRIMARY KEY (logger, size, start, channel)
    )
    readings_extremes_todo (logger PRIMARY KEY, below INTEGER NOT NULL)

(PostgreSQL: ``double precision``, ``bigint``). The rule of ``tmin``/``tmax`` is SQLite's
own for a bare column beside a lone ``min``/``max`` (the first row in key order with the
value; the last row when all are NULL), which the dashboard has always shown.

**Kept per batch** (:func:`after_batch_sqlite`, :func:`after_batch_postgres`: one call in
each sink, in the batch's transaction, after its rows are stored): per logger of the batch
the stored rows of its time span are grouped into the finest blocks and merged into the
table (:data:`MERGE`: one statement), then each coarser block over them is computed again
from the finer ones (one statement per size). Rows read back from ``readings`` are what is
stored: a row the store ignored as a duplicate counts with its stored value, and merging a
row twice changes nothing. The first batch makes the tables (:func:`ensure_sqlite`,
:func:`ensure_postgres`) and notes each logger that already has rows in
``readings_extremes_todo``: its blocks below ``below`` (a day boundary) miss the rows stored
before; :mod:`.blocks_fill` fills them in the background, a day at a time, and the dashboard
reads the rows there meanwhile. The table of the opt-in trigger of before
(``readings_blocks`` and its trigger) is dropped then.
"""

from __future__ import annotations

import itertools
import sqlite3
from collections.abc import Iterable, Sequence
from datetime import UTC, datetime
from typing import Any

from sondalog.collect.blocks_rule import CONFLICT, MERGE, REPLACE, aggregate, epoch
from sondalog.collect.model import Reading
from sondalog.collect.schema import EXTREMES, EXTREMES_SIZES, EXTREMES_TODO

SIZES = EXTREMES_SIZES
DAY = SIZES[-1]
TABLE = EXTREMES
TODO = EXTREMES_TODO
_LOCK_ID = 0x50D4_B10D  # advisory lock of the PostgreSQL tables' making
_COLS = "logger, size, start, channel, vmin, tmin, vmax, tmax"


def _pick(which: str, source: str) -> str:
    """SQLite: per ``(s, channel)`` of ``source`` (rows of ``s, channel, v, t`` in time
    order) its smallest (``which`` = ``min``) or largest ``v`` with the earliest ``t`` that
    has it, or, with every ``v`` NULL, NULL and the latest ``t``: the bare column beside a
    lone ``min``/``max`` (PostgreSQL: :func:`_pg_agg`)."""
    return f"SELECT s, channel, {which}(v) AS v, t FROM ({source}) GROUP BY s, channel"


def _both(source_min: str, source_max: str, size: int) -> str:
    """``logger, size, start, channel, vmin, tmin, vmax, tmax`` of the groups ``(s,
    channel)`` of two sources (``s, channel, v, t``: the candidates of each extreme)."""
    lo, hi = _pick("min", source_min), _pick("max", source_max)
    return (
        f"SELECT ?, {size}, a.s, a.channel, a.v, a.t, b.v, b.t FROM ({lo}) a "
        f"JOIN ({hi}) b ON a.s = b.s AND a.channel = b.channel WHERE a.s IS NOT NULL"
    )


def _fine() -> str:
    """SQLite: the finest blocks of a logger's stored rows in ``[?, ?]``, merged in."""
    size = SIZES[0]
    rows = (
        f"SELECT unixepoch(time) / {size} * {size} AS s, channel, value AS v, "
        "unixepoch(time) AS t FROM readings "
        "WHERE logger = ? AND time >= ? AND time <= ? AND channel > 0"
    )
    select = _both(rows, rows, size)
    return f"INSERT INTO {TABLE} ({_COLS}) {select} {CONFLICT}{MERGE}"


def _coarse(size: int, finer: int) -> str:
    """SQLite: the blocks of ``size`` over a logger's blocks of ``finer`` with ``start`` in
    ``[?, ?)``, made again from them."""

    def source(which: str) -> str:
        return (
            f"SELECT start / {size} * {size} AS s, channel, v{which} AS v, t{which} AS t "
            f"FROM {TABLE} WHERE logger = ? AND size = {finer} AND start >= ? AND start < ?"
        )

    select = _both(source("min"), source("max"), size)
    return f"INSERT INTO {TABLE} ({_COLS}) {select} {CONFLICT}{REPLACE}"


#: SQLite: the statements that bring one logger's blocks up to date with its rows in a
#: span, ``(sql, size, finer)`` (the finest: ``finer`` 0), in order.
_SQLITE = [(_fine(), SIZES[0], 0)]
_SQLITE += [(_coarse(s, f), s, f) for f, s in itertools.pairwise(SIZES)]


def _text(seconds: int) -> str:
    return datetime.fromtimestamp(seconds, UTC).strftime("%Y-%m-%dT%H:%M:%S")


def spans(batch: Iterable[Reading]) -> dict[str, tuple[datetime, datetime]]:
    """Each logger's first and last time in ``batch`` (channels > 0)."""
    out: dict[str, tuple[datetime, datetime]] = {}
    for r in batch:
        if r.channel <= 0:
            continue
        got = out.get(r.logger)
        if got is None:
            out[r.logger] = (r.time, r.time)
        elif r.time < got[0]:
            out[r.logger] = (r.time, got[1])
        elif r.time > got[1]:
            out[r.logger] = (got[0], r.time)
    return out


def params(logger: str, lo: Any, hi: Any, lo_s: int, hi_s: int) -> list[list[object]]:
    """The parameters of :func:`statements` for ``logger``'s rows in ``[lo, hi]`` (the
    store's times) whose seconds are ``lo_s .. hi_s``."""
    out: list[list[object]] = []
    for _, size, finer in _SQLITE:
        if finer == 0:
            out.append([logger, logger, lo, hi, logger, lo, hi])
        else:
            a, b = lo_s // size * size, (hi_s // size + 1) * size
            out.append([logger, logger, a, b, logger, a, b])
    return out


_UPSERT = f"INSERT INTO {TABLE} ({_COLS}) VALUES (?, ?, ?, ?, ?, ?, ?, ?) {CONFLICT}{MERGE}"
_PG_UPSERT = (
    f"INSERT INTO {TABLE} ({_COLS}) SELECT * FROM unnest(%b::text[], %b::int[], %b::bigint[], "
    f"%b::int[], %b::float8[], %b::bigint[], %b::float8[], %b::bigint[]) {CONFLICT}{MERGE}"
)  # binary parameters: psycopg's text form quotes every element (a fifth of the cost)


# -- SQLite -----------------------------------------------------------------------------------

SQLITE_DDL = f"""
CREATE TABLE IF NOT EXISTS {TABLE} (
    logger  TEXT    NOT NULL,
    size    INTEGER NOT NULL,
    start   INTEGER NOT NULL,
    channel INTEGER NOT NULL,
    vmin    REAL,
    tmin    INTEGER NOT NULL,
    vmax    REAL,
    tmax    INTEGER NOT NULL,
    PRIMARY KEY (logger, size, start, channel)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS {TODO} (logger TEXT PRIMARY KEY, below INTEGER NOT NULL);
"""
_LOGGERS = (
    "WITH RECURSIVE l(x) AS (SELECT min(logger) FROM readings UNION ALL "
    "SELECT (SELECT min(logger) FROM readings WHERE logger > x) FROM l "
    "WHERE x IS NOT NULL) SELECT x, (SELECT max(time) FROM readings WHERE logger = x) "
    "FROM l WHERE x IS NOT NULL"
)


def has_sqlite(conn: sqlite3.Connection) -> bool:
    """Whether the file has the tables (so every batch since keeps them)."""
    row = conn.execute(
        "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = ?", (TABLE,)
    ).fetchone()
    return bool(row[0])


def ensure_sqlite(conn: sqlite3.Connection) -> bool:
    """Make the tables in a transaction already open on ``conn`` (the batch's, or the
    filler's), noting every logger with rows as to be filled. True when made now."""
    if has_sqlite(conn):
        return False
    conn.execute("DROP TRIGGER IF EXISTS readings_blocks_add")  # the opt-in of before
    conn.execute("DROP TABLE IF EXISTS readings_blocks")
    for sql in SQLITE_DDL.split(";"):
        if sql.strip():
            conn.execute(sql)
    todo = [
        (logger, (epoch(datetime.fromisoformat(last)) // DAY + 1) * DAY)
        for logger, last in conn.execute(_LOGGERS).fetchall()
    ]
    conn.executemany(f"INSERT OR REPLACE INTO {TODO} (logger, below) VALUES (?, ?)", todo)
    return True


def after_batch_sqlite(
    conn: sqlite3.Connection, batch: Sequence[Reading], stored: int | None = None
) -> None:
    """The blocks of ``batch``'s spans brought up to date (the sink calls this in the
    batch's transaction, after ``INSERT OR IGNORE`` of its rows; ``stored``: how many it
    stored). Every row stored: merged from the batch (:func:`aggregate`, one statement);
    else from the rows read back (what is stored counts)."""
    found = spans(batch)
    if not found:
        return
    ensure_sqlite(conn)
    if stored == len(batch):
        conn.executemany(_UPSERT, aggregate(batch))
        return
    for logger, (lo, hi) in found.items():
        update_sqlite(conn, logger, lo.isoformat(timespec="seconds"), epoch(lo), epoch(hi))


def update_sqlite(conn: sqlite3.Connection, logger: str, lo: str, lo_s: int, hi_s: int) -> None:
    """``logger``'s blocks up to date with its rows in ``[lo_s, hi_s]`` seconds (``lo`` the
    text of ``lo_s``; the last second is included whole)."""
    hi = _text(hi_s)
    for (sql, _, _), args in zip(_SQLITE, params(logger, lo, hi, lo_s, hi_s), strict=True):
        conn.execute(sql, args)


# -- PostgreSQL -------------------------------------------------------------------------------

POSTGRES_DDL = (
    f"CREATE TABLE IF NOT EXISTS {TABLE} (logger text NOT NULL, size integer NOT NULL, "
    "start bigint NOT NULL, channel integer NOT NULL, vmin double precision, "
    "tmin bigint NOT NULL, vmax double precision, tmax bigint NOT NULL, "
    "PRIMARY KEY (logger, size, start, channel))",
    f"CREATE TABLE IF NOT EXISTS {TODO} (logger text PRIMARY KEY, below bigint NOT NULL)",
)
#: Connections (by id, with the connection kept so the id is not reused) that made sure of
#: the tables.
_ENSURED: dict[int, Any] = {}


def ensure_postgres_sql() -> list[str]:
    """The statements that make the tables on a server (under an advisory lock, in the
    caller's transaction), dropping the opt-in trigger of before."""
    return [
        f"SELECT pg_advisory_xact_lock({_LOCK_ID})",
        "DROP TRIGGER IF EXISTS readings_blocks_add ON readings",
        "DROP TABLE IF EXISTS readings_blocks",
        "DROP FUNCTION IF EXISTS sondalog_readings_blocks_add()",
        *POSTGRES_DDL,
    ]


_PG_NEW = "SELECT to_regclass('readings_extremes') IS NULL"  # checked under the lock
#: (``record_rows``: PostgreSQL's ``readings`` is a view of it, schema version 2, over which
#: the server does not look ``min``/``max`` up in the key.)
_PG_TODO = (
    f"INSERT INTO {TODO} (logger, below) SELECT x, "
    f"(floor(extract(epoch FROM (SELECT max(time) FROM record_rows WHERE logger = x)) / {DAY}) "
    f"+ 1)::bigint * {DAY} FROM (WITH RECURSIVE l(x) AS (SELECT min(logger) FROM record_rows "
    "UNION ALL SELECT (SELECT min(logger) FROM record_rows WHERE logger > x) FROM l "
    "WHERE x IS NOT NULL) SELECT x FROM l WHERE x IS NOT NULL) k "
    "ON CONFLICT (logger) DO NOTHING"
)


def ensure_postgres_sync(cur: Any) -> bool:
    """As :func:`ensure_sqlite` on a server, with a psycopg (sync) cursor."""
    statements = ensure_postgres_sql()
    cur.execute(statements[0])
    new = cur.execute(_PG_NEW).fetchone()[0]
    if not new:
        return False
    for sql in statements[1:]:
        cur.execute(sql)
    cur.execute(_PG_TODO)
    return True


def _pg_agg(source: str, size: int, v: tuple[str, str], t: tuple[str, str], keep: str) -> str:
    """The blocks of ``size`` of ``source`` (``logger, s, channel`` and the candidates'
    values ``v`` and times ``t`` of each extreme) put in the table (``keep``: the ``SET``)."""

    def first(value: str, time: str, order: str) -> str:
        ties = f"CASE WHEN {value} IS NULL THEN {time} END DESC, {time}"
        return f"(array_agg({time} ORDER BY {value}{order} NULLS LAST, {ties}))[1]"

    return (
        f"INSERT INTO {TABLE} ({_COLS}) SELECT logger, {size}, s, channel, "
        f"min({v[0]}), {first(v[0], t[0], '')}, max({v[1]}), {first(v[1], t[1], ' DESC')} "
        f"FROM ({source}) q GROUP BY logger, s, channel {CONFLICT}{keep}"
    )


_PG_RANGES = "unnest(%s::text[], %s::timestamp[], %s::timestamp[]) AS r(logger, lo, hi)"
_PG_STARTS = "unnest(%s::text[], %s::bigint[], %s::bigint[]) AS r(logger, lo, hi)"


def _pg_statements() -> list[tuple[str, int]]:
    """Per batch on PostgreSQL: every logger's spans in one statement per size."""
    size = SIZES[0]
    at = "extract(epoch FROM x.time)::bigint"
    rows = (
        f"SELECT x.logger, {at} / {size} * {size} AS s, x.channel, x.value, {at} AS t "
        f"FROM {_PG_RANGES} JOIN readings x ON x.logger = r.logger AND x.time >= r.lo "
        "AND x.time <= r.hi WHERE x.channel > 0"
    )
    out = [(_pg_agg(rows, size, ("value", "value"), ("t", "t"), MERGE), 0)]
    for finer, coarse in itertools.pairwise(SIZES):
        blocks = (
            f"SELECT e.logger, e.start / {coarse} * {coarse} AS s, e.channel, e.vmin, e.tmin, "
            f"e.vmax, e.tmax FROM {_PG_STARTS} JOIN {TABLE} e ON e.logger = r.logger "
            f"AND e.size = {finer} AND e.start >= r.lo AND e.start < r.hi"
        )
        out.append((_pg_agg(blocks, coarse, ("vmin", "vmax"), ("tmin", "tmax"), REPLACE), coarse))
    return out


_PG_BATCH = _pg_statements()
#: Whether the sink's batch went through its temporary table (some rows were there already).


def _pg_params(found: dict[str, tuple[int, int]]) -> list[list[object]]:
    loggers = list(found)
    spans_s = list(found.values())
    out: list[list[object]] = [
        [
            loggers,
            [datetime.fromtimestamp(a, UTC).replace(tzinfo=None) for a, _ in spans_s],
            [datetime.fromtimestamp(b, UTC).replace(tzinfo=None) for _, b in spans_s],
        ]
    ]
    for _, size in _PG_BATCH[1:]:
        out.append(
            [
                loggers,
                [a // size * size for a, _ in spans_s],
                [(b // size + 1) * size for _, b in spans_s],
            ]
        )
    return out


async def after_batch_postgres(
    cur: Any,
    batch: Sequence[Reading],
    stored: int,
    blocks: list[tuple[Any, ...]] | None = None,
) -> None:
    """As :func:`after_batch_sqlite` for the PostgreSQL sink (``cur``: its psycopg async
    cursor, in the batch's transaction after ``stored`` of the batch's rows were stored).
    Every row stored: merged from the batch in one statement (``blocks``: the batch's
    :func:`aggregate`, when the sink computed it while the server stored the rows); else
    every logger's rows read back, one statement per size."""
    whole = stored == len(batch)
    if whole:
        rows = aggregate(batch) if blocks is None else blocks
        if not rows:
            return
    elif not (found := spans(batch)):
        return
    conn = cur.connection
    if _ENSURED.get(id(conn)) is not conn:
        statements = ensure_postgres_sql()
        await cur.execute(statements[0])
        if (await (await cur.execute(_PG_NEW)).fetchone())[0]:
            for sql in statements[1:]:
                await cur.execute(sql)
            await cur.execute(_PG_TODO)
        for key in [k for k, c in _ENSURED.items() if c.closed]:
            del _ENSURED[key]
        _ENSURED[id(conn)] = conn
    if whole:
        await cur.execute(_PG_UPSERT, [list(col) for col in zip(*rows, strict=True)])
        return
    secs = {logger: (epoch(lo), epoch(hi)) for logger, (lo, hi) in found.items()}
    for (sql, _), args in zip(_PG_BATCH, _pg_params(secs), strict=True):
        await cur.execute(sql, args)


def update_postgres_sync(cur: Any, logger: str, lo_s: int, hi_s: int) -> None:
    """As :func:`update_sqlite` on a server, with a psycopg (sync) cursor."""
    for (sql, _), args in zip(_PG_BATCH, _pg_params({logger: (lo_s, hi_s)}), strict=True):
        cur.execute(sql, args)

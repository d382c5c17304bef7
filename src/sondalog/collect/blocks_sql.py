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
from the finer ones (one statement per size; on PostgreSQL every size in one statement from
the span's rows, :data:`PG_ROWS`). Rows read back from ``readings`` are what is
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


def upsert_params(blocks: Sequence[tuple[Any, ...]]) -> list[bytes]:
    """The parameters of the PostgreSQL upsert of ``blocks`` (rows of the table): its eight
    columns as arrays encoded at once (:mod:`.pg_arrays`; psycopg's dumping of lists, Python
    element by element, was the largest share of the collector's CPU of a batch). Imported
    here: the SQLite store and the dashboard use this module without psycopg."""
    from sondalog.collect import pg_arrays

    lg, size, start, ch, vmin, tmin, vmax, tmax = zip(*blocks, strict=True)
    return [
        pg_arrays.texts(lg),
        pg_arrays.int4s(size),
        pg_arrays.int8s(start),
        pg_arrays.int4s(ch),
        pg_arrays.float8s(vmin),
        pg_arrays.int8s(tmin),
        pg_arrays.float8s(vmax),
        pg_arrays.int8s(tmax),
    ]


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


def _pg_extremes(v: tuple[str, str], t: tuple[str, str]) -> str:
    """``vmin, tmin, vmax, tmax`` of a group of candidates (the values ``v`` and times ``t``
    of each extreme) by the rule of :mod:`.blocks_rule`: ``min``/``max`` of ``ARRAY[value,
    time]`` pairs (arrays compare element by element: the smallest value, on a tie the
    earliest time; ``-time`` for the largest value), and with every value NULL the latest
    time. Plain aggregates, so the server groups by hashing (an ``array_agg(... ORDER BY)``
    sorted every group: measured 1.7x the time)."""
    (vn, vx), (tn, tx) = v, t
    return (
        f"min({vn}), coalesce((min(ARRAY[{vn}, {tn}]) FILTER (WHERE {vn} IS NOT NULL))[2]"
        f"::bigint, max({tn})), max({vx}), coalesce(-(max(ARRAY[{vx}, -{tx}]) FILTER (WHERE "
        f"{vx} IS NOT NULL))[2]::bigint, max({tx}))"
    )


def _pg_rows_sql() -> str:
    """The blocks of every size of one logger's stored rows in ``[%(lo)s, %(hi)s]`` (the
    store's times), merged into the table (:data:`MERGE`) in one statement.

    The rows are read from ``record_rows`` (schema version 2; the ``readings`` view joins
    each row to its subscripts, and a join with a list of spans made the server scan every
    row of the logger), one index range, and only their channels and values are unnested
    (in the select list: 2.5 times as fast as ``unnest`` in ``FROM``, which puts each row's
    readings in a table first); a row's time is computed once (``OFFSET 0`` keeps it
    there), not once a reading.
    Every size is made from the finest blocks of the span (a ``MATERIALIZED`` CTE), so a
    block at the span's edge merges the extremes of the span's rows into the stored ones
    (merging is a union: exact, and so under a concurrent batch too)."""
    fine = SIZES[0]
    at = "extract(epoch FROM time)::bigint"
    rows = (
        f"SELECT t / {fine} * {fine} AS s, channel, value, t FROM (SELECT t, unnest(channel) "
        f"AS channel, unnest(value) AS value FROM (SELECT {at} AS t, channel, value FROM "
        "record_rows WHERE logger = %(logger)s AND time >= %(lo)s AND time <= %(hi)s "
        "OFFSET 0) x) u WHERE channel > 0"
    )
    cte = (
        "WITH f (s, channel, vmin, tmin, vmax, tmax) AS MATERIALIZED (SELECT s, channel, "
        f"{_pg_extremes(('value', 'value'), ('t', 't'))} FROM ({rows}) q GROUP BY s, channel)"
    )
    parts = [f"SELECT %(logger)s, {fine}, f.* FROM f"]
    for size in SIZES[1:]:
        parts.append(
            f"SELECT %(logger)s, {size}, f.s / {size} * {size}, f.channel, "
            f"{_pg_extremes(('f.vmin', 'f.vmax'), ('f.tmin', 'f.tmax'))} FROM f "
            f"GROUP BY f.s / {size} * {size}, f.channel"
        )
    union = " UNION ALL ".join(parts)
    return f"{cte} INSERT INTO {TABLE} ({_COLS}) {union} {CONFLICT}{MERGE}"


#: One logger's span of stored rows into the blocks of every size (:func:`_pg_rows_sql`).
PG_ROWS = _pg_rows_sql()


def _naive(seconds: int) -> datetime:
    return datetime.fromtimestamp(seconds, UTC).replace(tzinfo=None)


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
    every logger's rows read back (:data:`PG_ROWS`, one statement a logger)."""
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
        from sondalog.collect import pg_arrays  # psycopg: not for SQLite's users

        pg_arrays.register(conn)  # the upsert's arrays (cursors copy the adapters when made)
        pg_arrays.register(cur)
        _ENSURED[id(conn)] = conn
    if whole:
        await cur.execute(_PG_UPSERT, upsert_params(rows))
        return
    for logger, (lo, hi) in found.items():
        # not prepared: planned with the span's values, so the key's index range is used
        # (a generic plan may take the time's BRIN, every logger's rows of the span)
        await cur.execute(PG_ROWS, {"logger": logger, "lo": lo, "hi": hi}, prepare=False)


def update_postgres_sync(cur: Any, logger: str, lo_s: int, hi_s: int) -> None:
    """As :func:`update_sqlite` on a server, with a psycopg (sync) cursor: one statement."""
    span = {"logger": logger, "lo": _naive(lo_s), "hi": _naive(hi_s)}
    cur.execute(PG_ROWS, span, prepare=False)

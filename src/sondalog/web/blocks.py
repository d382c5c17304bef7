"""Each channel's extremes per block of time, kept at ingest, for the plot's long ranges (issue 24).

A plot of a long range sends, per bucket, each channel's smallest and largest value with the
time of a reading that has it (:mod:`.series`). Read from ``readings`` that is every row of
the range (a year of 12 channels at 1 minute: 6.3 million); the table ``readings_blocks``
keeps the same answer for fixed blocks of time, so a bucket is read as its blocks plus the
raw readings at its two ends::

    readings_blocks (
        logger  TEXT    NOT NULL,  -- as readings.logger
        size    INTEGER NOT NULL,  -- the block's length: 300 or 3600 seconds (SIZES)
        start   INTEGER NOT NULL,  -- its start: seconds since 1970 of the logger's clock
                                   -- read as UTC (as the plot's x), a multiple of size
        channel INTEGER NOT NULL,  -- > 0 (text rows have no value)
        vmin    REAL,              -- the smallest value, NULL when every value is NULL
        tmin    TEXT    NOT NULL,  -- the earliest time with vmin; every value NULL: the latest time
        vmax    REAL,              -- the largest value, likewise
        tmax    TEXT    NOT NULL,
        PRIMARY KEY (logger, size, start, channel)
    )

(on PostgreSQL ``double precision``, ``timestamp`` and ``bigint`` as in its ``readings``).
The rule of ``tmin``/``tmax`` is SQLite's own for a bare column beside a lone ``min``/``max``
(the first row in key order that has the value; the last row when all are NULL), which the
dashboard has always shown, so a bucket made of blocks is exactly the bucket made of rows.
Combining two of them (a block and a new reading, or two blocks) keeps the rule: see
:data:`MERGE`.

The table is filled at ingest by a trigger on ``readings`` (SQLite: per row; PostgreSQL: per
statement, over its transition table, so one ``COPY``-fed ``INSERT`` of a batch merges the
batch once); ``INSERT OR IGNORE``/``ON CONFLICT DO NOTHING`` of a row already stored fires
nothing. :func:`install_sqlite`/:func:`install_postgres` create table and trigger and fill
the table from the stored rows in one transaction (idempotent; the collector's dashboard
wiring calls them, ``sondalog.app.collector``). The dashboard itself only reads: a store
without the table is read from its rows (slower, same answer). A TimescaleDB hypertable
takes no transition-table trigger: there the table is not made.
"""

from __future__ import annotations

import math
import sqlite3
from collections.abc import Iterator, Sequence
from typing import Any

from .db import Db
from .times import from_epoch

#: Block lengths (seconds), finest first.
SIZES = (300, 3600)
#: A block size serves buckets at least this many times as long.
WORTH = 4
_LOCK_ID = 0x50D4_B10C  # advisory lock of the PostgreSQL install


def _merge(v: str, t: str, better: str) -> str:
    """``SET`` of one extreme: the stored block (``readings_blocks``) takes the new one
    (``excluded``; a reading is a block of one) when its value is ``better`` (``<``, ``>``),
    and on a tie the earlier time; NULL values lose to any value, and between blocks of
    NULLs only the later time wins."""
    old_v, old_t = f"readings_blocks.{v}", f"readings_blocks.{t}"
    new_v, new_t = f"excluded.{v}", f"excluded.{t}"
    takes = f"{old_v} IS NULL OR {new_v} {better} {old_v}"
    return (
        f"{v} = CASE WHEN {new_v} IS NULL THEN {old_v} WHEN {takes} THEN {new_v} "
        f"ELSE {old_v} END, "
        f"{t} = CASE WHEN {new_v} IS NULL THEN "
        f"CASE WHEN {old_v} IS NULL AND {new_t} > {old_t} THEN {new_t} ELSE {old_t} END "
        f"WHEN {takes} THEN {new_t} "
        f"WHEN {new_v} = {old_v} AND {new_t} < {old_t} THEN {new_t} ELSE {old_t} END"
    )


#: How a stored block takes a new one (:func:`_merge`); the same SQL on both servers.
MERGE = _merge("vmin", "tmin", "<") + ", " + _merge("vmax", "tmax", ">")
_INSERT = "INSERT INTO readings_blocks (logger, size, start, channel, vmin, tmin, vmax, tmax) "
_SIZES_SQLITE = " UNION ALL ".join(f"SELECT {s} AS size" for s in SIZES)

SQLITE_DDL = """
CREATE TABLE IF NOT EXISTS readings_blocks (
    logger  TEXT    NOT NULL,
    size    INTEGER NOT NULL,
    start   INTEGER NOT NULL,
    channel INTEGER NOT NULL,
    vmin    REAL,
    tmin    TEXT    NOT NULL,
    vmax    REAL,
    tmax    TEXT    NOT NULL,
    PRIMARY KEY (logger, size, start, channel)
) WITHOUT ROWID
"""


def _sqlite_rows(source: str, where: str) -> str:
    """Each row of ``source`` as a block of one per size (upsert-from-select needs a WHERE)."""
    return (
        _INSERT
        + f"SELECT x.logger, s.size, unixepoch(x.time) / s.size * s.size, x.channel, x.value, "
        f"x.time, x.value, x.time FROM {source}, ({_SIZES_SQLITE}) s WHERE {where} "
        f"ON CONFLICT (logger, size, start, channel) DO UPDATE SET {MERGE}"
    )


#: Per size one plain upsert of the new row (no compound SELECT per row: cheaper at ingest).
SQLITE_TRIGGER = (
    "CREATE TRIGGER IF NOT EXISTS readings_blocks_add AFTER INSERT ON readings "
    "WHEN new.channel > 0 AND unixepoch(new.time) IS NOT NULL BEGIN "
    + "".join(
        _INSERT + f"VALUES (new.logger, {size}, unixepoch(new.time) / {size} * {size}, "
        "new.channel, new.value, new.time, new.value, new.time) "
        f"ON CONFLICT (logger, size, start, channel) DO UPDATE SET {MERGE}; "
        for size in SIZES
    )
    + "END"
)
SQLITE_FILL = _sqlite_rows("readings x", "x.channel > 0 AND unixepoch(x.time) IS NOT NULL")


def installed_sqlite(conn: sqlite3.Connection) -> bool:
    found = {
        (r[0], r[1])
        for r in conn.execute(
            "SELECT type, name FROM sqlite_master WHERE name IN "
            "('readings_blocks', 'readings_blocks_add')"
        )
    }
    return found == {("table", "readings_blocks"), ("trigger", "readings_blocks_add")}


def install_sqlite(conn: sqlite3.Connection) -> bool:
    """Make table and trigger in the collector's file and fill the table from its rows, in
    one ``BEGIN IMMEDIATE`` transaction; nothing when both are there. True when made now."""
    if installed_sqlite(conn):
        return False
    conn.execute("BEGIN IMMEDIATE")
    try:
        if installed_sqlite(conn):
            conn.execute("ROLLBACK")
            return False
        conn.execute("DROP TRIGGER IF EXISTS readings_blocks_add")
        conn.execute("DROP TABLE IF EXISTS readings_blocks")
        conn.execute(SQLITE_DDL)
        conn.execute(SQLITE_TRIGGER)
        conn.execute(SQLITE_FILL)
        conn.execute("COMMIT")
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    return True


POSTGRES_DDL = """
CREATE TABLE IF NOT EXISTS readings_blocks (
    logger  text             NOT NULL,
    size    integer          NOT NULL,
    start   bigint           NOT NULL,
    channel integer          NOT NULL,
    vmin    double precision,
    tmin    timestamp        NOT NULL,
    vmax    double precision,
    tmax    timestamp        NOT NULL,
    PRIMARY KEY (logger, size, start, channel)
)
"""
_PG_SIZES = ", ".join(f"({s})" for s in SIZES)


def _postgres_merge(source: str) -> str:
    """The blocks of the rows of ``source``, merged into the table (one statement)."""
    nulls_last = "CASE WHEN value IS NULL THEN time END DESC, time"
    return (
        _INSERT + "SELECT logger, size, start, channel, "
        f"min(value), (array_agg(time ORDER BY value NULLS LAST, {nulls_last}))[1], "
        f"max(value), (array_agg(time ORDER BY value DESC NULLS LAST, {nulls_last}))[1] "
        "FROM (SELECT x.logger, s.size, "
        "(floor(extract(epoch FROM x.time) / s.size) * s.size)::bigint AS start, "
        f"x.channel, x.value, x.time FROM {source} x CROSS JOIN (VALUES {_PG_SIZES}) s(size) "
        "WHERE x.channel > 0) n GROUP BY logger, size, start, channel "
        f"ON CONFLICT (logger, size, start, channel) DO UPDATE SET {MERGE}"
    )


POSTGRES_FUNCTION = (
    "CREATE OR REPLACE FUNCTION sondalog_readings_blocks_add() RETURNS trigger "
    "LANGUAGE plpgsql AS $body$ BEGIN " + _postgres_merge("new_rows") + "; RETURN NULL; END $body$"
)
POSTGRES_TRIGGER = (
    "CREATE TRIGGER readings_blocks_add AFTER INSERT ON readings "
    "REFERENCING NEW TABLE AS new_rows FOR EACH STATEMENT "
    "EXECUTE FUNCTION sondalog_readings_blocks_add()"
)


def install_postgres(conn: Any) -> bool:
    """As :func:`install_sqlite` on the ``[postgres]`` server (``conn``: a psycopg
    connection in autocommit mode), under an advisory lock and with ``readings`` locked
    against inserts while it is filled. Nothing on a TimescaleDB hypertable (False), or
    before the sink made ``readings`` (False: call again later)."""
    with conn.transaction():
        conn.execute("SELECT pg_advisory_xact_lock(%s)", (_LOCK_ID,))
        if conn.execute("SELECT to_regclass('readings')").fetchone()[0] is None:
            return False
        hyper = conn.execute(
            "SELECT value FROM meta WHERE key = 'layout'"
            if conn.execute("SELECT to_regclass('meta')").fetchone()[0] is not None
            else "SELECT NULL"
        ).fetchone()
        if hyper and hyper[0] == "hypertable":
            return False
        there = conn.execute(
            "SELECT count(*) FROM pg_trigger WHERE tgname = 'readings_blocks_add' "
            "AND tgrelid = 'readings'::regclass"
        ).fetchone()[0]
        if there and conn.execute("SELECT to_regclass('readings_blocks')").fetchone()[0]:
            return False
        conn.execute("LOCK TABLE readings IN SHARE ROW EXCLUSIVE MODE")
        conn.execute("DROP TRIGGER IF EXISTS readings_blocks_add ON readings")
        conn.execute("DROP TABLE IF EXISTS readings_blocks")
        conn.execute(POSTGRES_DDL)
        conn.execute(POSTGRES_FUNCTION)
        conn.execute(POSTGRES_TRIGGER)
        conn.execute(_postgres_merge("readings"))
    return True


# -- reading: a bucket as raw rows, blocks, raw rows ------------------------------------------

_RAW = "SELECT channel, value AS v, time AS t FROM readings WHERE logger = ? AND time >= ? "
_RAW += "AND time < ? AND channel > 0"


def _blocks(size: int, which: str) -> str:
    return (
        f"SELECT channel, v{which} AS v, t{which} AS t FROM readings_blocks "
        f"WHERE logger = ? AND size = {size} AND start >= ? AND start < ?"
    )


def pieces(a: int, b: int, sizes: Sequence[int] = SIZES) -> list[tuple[int, int, int]]:
    """``[a, b)`` (seconds) as ``(size, lo, hi)`` in time order: raw rows (``size`` 0)
    at the ends, then blocks of ``sizes`` (finest first) as large as fit, each aligned."""
    if a >= b:
        return []
    if not sizes:
        return [(0, a, b)]
    size, rest = sizes[-1], sizes[:-1]
    lo, hi = -(-a // size) * size, b // size * size
    if lo >= hi:
        return pieces(a, b, rest)
    return [*pieces(a, lo, rest), (size, lo, hi), *pieces(hi, b, rest)]


def _query(dialect: Any, layout: tuple[int, ...]) -> str:
    """The SQL of a bucket whose pieces are ``layout`` (their sizes, 0: raw)."""
    out = []
    for which in ("min", "max"):
        arms = [_RAW if size == 0 else _blocks(size, which) for size in layout]
        inner = dialect.extreme(which, " UNION ALL ".join(arms))
        at = dialect.epoch("t")  # seconds, as the plot's x: no conversion per point in Python
        out.append(f"SELECT channel, {0 if which == 'min' else 1}, v, {at} FROM ({inner}) e{which}")
    return " UNION ALL ".join(out)


def extremes(
    db: Db, logger: str, edges: Sequence[str], *, use_blocks: bool | None = None
) -> Iterator[tuple[int, int, int, float | None, int]]:
    """``(bucket, channel, which, value, time)`` as :func:`~.store.bucketed` gives them, for
    buckets ``[edges[i], edges[i+1])`` (whole seconds), on either store, but ``time`` in
    seconds since 1970 (:func:`~.times.to_epoch` of the text); from the blocks when the
    store has them (``use_blocks`` None) or when told. A block size is used only for
    buckets at least :data:`WORTH` times as long (shorter ones read fewer rows raw)."""
    from .times import to_epoch

    blocks = db.has_blocks if use_blocks is None else use_blocks
    queries: dict[tuple[int, ...], list[tuple[int, list[object]]]] = {}
    at = [to_epoch(e) for e in edges]
    width = at[1] - at[0] if len(at) > 1 else 0
    sizes = tuple(s for s in SIZES if blocks and width >= WORTH * s)
    for i in range(len(edges) - 1):
        parts = pieces(at[i], at[i + 1], sizes)
        params: list[object] = []
        for size, lo, hi in parts:
            params += [logger, from_epoch(lo), from_epoch(hi)] if size == 0 else [logger, lo, hi]
        queries.setdefault(tuple(p[0] for p in parts), []).append((i, params + params))
    for layout, runs in queries.items():
        if db.dialect.postgres:
            yield from _lateral(db, layout, runs)
            continue
        sql = db.dialect.sql(_query(db.dialect, layout))
        for i, params in runs:
            for ch, which, value, time in db.conn.execute(sql, params):
                yield i, ch, which, value, time


def _lateral(
    db: Db, layout: tuple[int, ...], runs: list[tuple[int, list[object]]]
) -> Iterator[tuple[int, int, int, float | None, int]]:
    """Every bucket of one layout in one statement on PostgreSQL: the buckets' parameters
    as arrays (``unnest``), the bucket's query (the same text as on SQLite, its ``?`` now
    the row's columns) run for each (``CROSS JOIN LATERAL``): one round trip, one plan."""
    text = _query(db.dialect, layout)
    parts = text.split("?")
    half = (len(parts) - 1) // 2  # the min and the max half take the same parameters
    sql = parts[0] + "".join(f"b.c{j % half}{rest}" for j, rest in enumerate(parts[1:]))
    kinds = [
        kind
        for size in layout
        for kind in ("text", *(("timestamp",) * 2 if size == 0 else ("bigint",) * 2))
    ]
    arrays = ", ".join(f"%s::{kind}[]" for kind in kinds)
    columns = ", ".join(f"c{k}" for k in range(half))
    query = (
        f"SELECT b.i, e.* FROM unnest(%s::int[], {arrays}) AS b(i, {columns}) "
        f"CROSS JOIN LATERAL ({sql}) e"
    )
    params: list[object] = [[i for i, _ in runs]]
    params += [[p[k] for _, p in runs] for k in range(half)]
    yield from db.conn.execute(query, params)


def bucket_edges(lo: str, hi: str, buckets: int) -> tuple[list[str], int]:
    """The edges of ``buckets`` equal buckets over ``[lo, hi]`` and their width (seconds),
    as the plot cuts a long range (:mod:`.series`)."""
    from .times import to_epoch

    start, end = to_epoch(lo), to_epoch(hi) + 1
    width = max(1, math.ceil((end - start) / buckets))
    n = math.ceil((end - start) / width)
    return [from_epoch(start + i * width) for i in range(n + 1)], width

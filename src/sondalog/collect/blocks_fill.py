"""The per-block extremes of the rows stored before the sinks kept them, filled in the
background (issue 24, :mod:`sondalog.collect.blocks_sql`).

The first batch after an upgrade makes the tables and notes in ``readings_extremes_todo``
each logger that had rows, with ``below``: the day boundary after its newest row. From then
on every batch keeps the blocks of its rows, and :func:`fill_step_sqlite` /
:func:`fill_step_postgres` bring a logger's blocks of the day below ``below`` up to date
from its rows, then lower ``below`` to the day of its next older row (no row left: the
logger is done), all in one short transaction: the collector's writer waits at most for
one day of one logger (about 17,000 rows at 12 channels a minute, tens of milliseconds).
On a server a step takes as many whole days as hold :data:`STEP_READINGS` readings (one
day at least) and makes their blocks of every size in one statement from ``record_rows``
(:data:`~sondalog.collect.blocks_sql.PG_ROWS`). The newest days come first (the ones a plot
shows first); the dashboard reads the rows below ``below`` meanwhile, so it never shows an
incomplete block. :func:`fill_file` and :func:`fill_server` run the steps until nothing is
left (the collector's dashboard wiring, :mod:`sondalog.app.collector`); several collectors
on one server share the work (``FOR UPDATE SKIP LOCKED``).
"""

from __future__ import annotations

import asyncio
import logging
import sqlite3
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sondalog.collect.blocks_sql import (
    DAY,
    TODO,
    ensure_postgres_sync,
    ensure_sqlite,
    update_postgres_sync,
    update_sqlite,
)

log = logging.getLogger(__name__)
#: Seconds between steps (the collector's writer goes first) and between tries to reach a
#: server that is not there yet.
PAUSE_S = 0.02
RETRY_S = 60.0


def _below(last: datetime | str | None) -> int | None:
    """The day boundary after ``last`` (a row's time, naive: read as UTC), seconds."""
    if last is None:
        return None
    at = datetime.fromisoformat(last) if isinstance(last, str) else last
    return (int(at.replace(tzinfo=UTC).timestamp()) // DAY + 1) * DAY


def _text(seconds: int) -> str:
    return datetime.fromtimestamp(seconds, UTC).strftime("%Y-%m-%dT%H:%M:%S")


def fill_step_sqlite(conn: sqlite3.Connection) -> bool:
    """One day of one logger in the file (``conn``: autocommit); False when none is left."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        ensure_sqlite(conn)
        row = conn.execute(
            f"SELECT logger, below FROM {TODO} ORDER BY below DESC LIMIT 1"
        ).fetchone()
        if row is None:
            conn.execute("COMMIT")
            return False
        logger, below = str(row[0]), int(row[1])
        lo = below - DAY
        update_sqlite(conn, logger, _text(lo), lo, below - 1)
        older = conn.execute(
            "SELECT max(time) FROM readings WHERE logger = ? AND time < ?", (logger, _text(lo))
        ).fetchone()[0]
        nxt = _below(older)
        if nxt is None:
            conn.execute(f"DELETE FROM {TODO} WHERE logger = ?", (logger,))
        else:
            conn.execute(f"UPDATE {TODO} SET below = ? WHERE logger = ?", (nxt, logger))
        conn.execute("COMMIT")
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    return True


#: A step on a server fills whole days of one logger's rows, as many as hold at most this
#: many readings (at least one day), a record row counting as :data:`ROW_READINGS` more:
#: about 2 days of 12 channels a minute, 13 of one.
STEP_READINGS = 60_000
#: What reading a record row costs a step beside its readings' (measured on the loaded
#: machine: about 2.6 us a reading and 4.5 a row; a step of 41 days of one channel took 2.7
#: times one of 3 days of 12 when rows were not counted).
ROW_READINGS = 2
#: The memory a step's grouping may take on the server (its default, 4 MB, made the server
#: sort a step's 60,000 readings on disk instead of hashing their blocks).
WORK_MEM = "32MB"
#: Where the newest days of ``logger`` below ``below`` with at most ``%(n)s`` readings (and
#: :data:`ROW_READINGS` a row) begin:
#: the time of the row past them (none: every row below fits). By the key, newest first.
_PG_PAST = (
    f"SELECT time FROM (SELECT time, sum(cardinality(channel) + {ROW_READINGS}) OVER (ORDER "
    "BY time DESC, counter DESC) AS n FROM record_rows WHERE logger = %(logger)s AND time < "
    "%(below)s) w "
    "WHERE n > %(n)s LIMIT 1"
)


def fill_step_postgres(conn: Any) -> bool:
    """As :func:`fill_step_sqlite` on a server (``conn``: a psycopg connection, autocommit),
    for the newest whole days of a logger below its ``below`` with at most
    :data:`STEP_READINGS` readings (one day at least): one statement makes their blocks of
    every size (:data:`~sondalog.collect.blocks_sql.PG_ROWS`)."""
    with conn.transaction(), conn.cursor() as cur:
        if cur.execute("SELECT to_regclass('record_rows')").fetchone()[0] is None:
            return False  # no sink of schema version 2 has written yet
        # short statements over one key range each: compiling them (JIT) took seconds; and
        # the step's blocks grouped in memory (a hash), not sorted on disk
        cur.execute("SET LOCAL jit = off")
        cur.execute(f"SET LOCAL work_mem = '{WORK_MEM}'")
        ensure_postgres_sync(cur)
        row = cur.execute(
            f"SELECT logger, below FROM {TODO} ORDER BY below DESC LIMIT 1 FOR UPDATE SKIP LOCKED"
        ).fetchone()
        if row is None:
            return False
        logger, below = str(row[0]), int(row[1])
        key = {"logger": logger, "below": _naive(below), "n": STEP_READINGS}
        past = cur.execute(_PG_PAST, key, prepare=False).fetchone()
        if past is None:  # every row below fits: from the day of the oldest
            # record_rows: the view readings hides the key from min() (schema_pg)
            oldest = cur.execute(
                "SELECT min(time) FROM record_rows WHERE logger = %s", (logger,)
            ).fetchone()[0]
            lo = below - DAY if oldest is None else min(below - DAY, (_below(oldest) or 0) - DAY)
        else:
            lo = min(below - DAY, _below(past[0]) or 0)
        update_postgres_sync(cur, logger, lo, below - 1)
        older = None
        if past is not None:
            older = cur.execute(
                "SELECT max(time) FROM record_rows WHERE logger = %s AND time < %s",
                (logger, _naive(lo)),
            ).fetchone()[0]
        nxt = _below(older)
        if nxt is None:
            cur.execute(f"DELETE FROM {TODO} WHERE logger = %s", (logger,))
        else:
            cur.execute(f"UPDATE {TODO} SET below = %s WHERE logger = %s", (nxt, logger))
    return True


def _naive(seconds: int) -> datetime:
    return datetime.fromtimestamp(seconds, UTC).replace(tzinfo=None)


async def fill_file(path: Path) -> None:
    """Fill the file's blocks until done (a task of the collector's loop)."""
    began, steps = time.monotonic(), 0
    conn = sqlite3.connect(path, isolation_level=None, timeout=60.0, check_same_thread=False)
    try:
        while await asyncio.to_thread(fill_step_sqlite, conn):
            steps += 1
            await asyncio.sleep(PAUSE_S)
    except sqlite3.Error as exc:  # the dashboard reads the rows instead (slower)
        log.warning("dashboard: long-range extremes not filled in %s: %s", path, exc)
        return
    finally:
        conn.close()
    if steps:
        log.info("dashboard: %d days of extremes filled in %.1f s", steps, time.monotonic() - began)


async def fill_server(dsn: str) -> None:
    """Fill the server's blocks until done, trying again while it cannot be reached."""
    import psycopg

    while True:
        try:
            conn: Any = await asyncio.to_thread(
                lambda: psycopg.connect(dsn, autocommit=True, connect_timeout=10)
            )
            try:
                while await asyncio.to_thread(fill_step_postgres, conn):
                    await asyncio.sleep(PAUSE_S)
            finally:
                conn.close()
            return
        except psycopg.Error as exc:
            log.warning("dashboard: long-range extremes not filled on the server yet: %s", exc)
        await asyncio.sleep(RETRY_S)

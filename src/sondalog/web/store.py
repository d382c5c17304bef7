"""Read-only queries on the collector's store (:mod:`sondalog.collect.schema`), written once
for its SQLite file and a PostgreSQL server (:mod:`.dialect`, :mod:`.db`).

Every query keeps to the ``readings`` primary key ``(logger, time, counter, channel)``: a
logger's rows in a time range are one index range, so the cost follows the rows asked for,
not the size of the store. The dashboard never writes: connections are read-only.

``sources``, ``events`` and the optional ``channels(logger, channel, name, unit, type,
format)`` are read from the collector's SQLite file (``db.file``), which only it has; with a
server alone (no file) there are none. ``channels`` (not part of schema version 1) gives
each channel's type when the collector fills it; a type-6 channel (§6.5.6.4, sporadic
pulses) is then drawn as bars. Without it every channel is a line and names and units come
from the readings themselves.
"""

from __future__ import annotations

import re
import sqlite3
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from itertools import groupby
from operator import itemgetter
from pathlib import Path
from typing import Any

from sondalog.collect.schema import COLUMNS

from .db import FILE_BLOCKS, Db, StoreUnavailable, connect_file
from .dialect import SQLITE

__all__ = ["Channel", "Db", "StoreUnavailable"]

#: How many of a logger's newest rows are read to find its channels and last values.
RECENT_ROWS = 4000


@dataclass(frozen=True)
class Channel:
    """A logger channel as the dashboard shows it."""

    channel: int
    name: str | None
    unit: str | None
    type: int | None = None
    last_time: str | None = None
    last_value: float | None = None
    #: Decimals of the channel's format (§6.5.7): from the format the collector read from
    #: the logger, else as its recent values show them (the most any of them has: the logger
    #: writes every value with its format's decimals); None without either.
    decimals: int | None = None

    @property
    def kind(self) -> str:
        """``bars`` for a type-6 (event) channel, §6.5.6.4; ``line`` otherwise."""
        return "bars" if self.type == 6 else "line"


def connect(path: Path) -> Db:
    """A read-only :class:`Db` on the collector's file at ``path`` (its readings too)."""
    return of_file(connect_file(path))


def of_file(conn: sqlite3.Connection) -> Db:
    """A :class:`Db` whose readings are in the SQLite connection ``conn`` (read-only or not:
    the queries only read)."""
    return Db(SQLITE, conn, conn, bool(conn.execute(FILE_BLOCKS).fetchone()[0]))


def _file_rows(db: Db, sql: str, params: Sequence[object] = ()) -> list[tuple[Any, ...]]:
    """Rows of the collector's file (none without one, or without the table: an older
    collector's file, or a file a collector with readings elsewhere has not filled)."""
    if db.file is None:
        return []
    try:
        return db.file.execute(sql, tuple(params)).fetchall()
    except sqlite3.OperationalError as exc:
        if "no such table" in str(exc):
            return []
        raise


def loggers(db: Db) -> list[str]:
    """Every logger with readings or a source, sorted (a skip scan over the key)."""
    keys = db.dialect.keys
    found = {
        row[0]
        for row in db.rows(
            f"WITH RECURSIVE l(x) AS (SELECT min(logger) FROM {keys} UNION ALL "
            f"SELECT (SELECT min(logger) FROM {keys} WHERE logger > x) FROM l "
            "WHERE x IS NOT NULL) SELECT x FROM l WHERE x IS NOT NULL"
        )
    }
    found.update(
        row[0] for row in _file_rows(db, "SELECT logger FROM sources WHERE logger IS NOT NULL")
    )
    return sorted(found)


def known(db: Db, logger: str) -> bool:
    """Whether ``logger`` has readings or a source."""
    if db.first("SELECT 1 FROM readings WHERE logger = ? LIMIT 1", (logger,)):
        return True
    return bool(_file_rows(db, "SELECT 1 FROM sources WHERE logger = ?", (logger,)))


def sources(db: Db) -> list[dict[str, Any]]:
    """The ``sources`` table as dicts, by name."""
    if db.file is None:
        return []
    try:
        cur = db.file.execute("SELECT * FROM sources ORDER BY name")
    except sqlite3.OperationalError as exc:
        if "no such table" in str(exc):
            return []
        raise
    cols = [d[0] for d in cur.description]
    return [dict(zip(cols, row, strict=True)) for row in cur]


def channels(db: Db, logger: str) -> list[Channel]:
    """The logger's channels with their last values, by channel number.

    From the optional ``channels`` table and the logger's newest :data:`RECENT_ROWS` rows
    (their channels and values; each channel's newest row read again for its time, name
    and unit, :func:`_newest`).
    """
    out: dict[int, Channel] = {}
    formats: dict[int, int] = {}
    columns = {row[1] for row in _file_rows(db, "PRAGMA table_info(channels)")}  # {}: none
    if columns:
        fmt = "format" if "format" in columns else "NULL"
        for ch, name, unit, typ, form in _file_rows(
            db, f"SELECT channel, name, unit, type, {fmt} FROM channels WHERE logger = ?", (logger,)
        ):
            out[int(ch)] = Channel(int(ch), name, unit, None if typ is None else int(typ))
            if form:
                formats[int(ch)] = format_decimals(str(form))
    d = db.dialect
    order = "ORDER BY time DESC, counter DESC"
    recent = db.rows(
        d.query("channel, value", "channel, time, counter, value", "logger = ?", order=order,
                limit=True, positive=False),
        (logger, RECENT_ROWS),
    )  # fmt: skip
    places: dict[int, int] = {}
    for ch, group in groupby(sorted(recent, key=itemgetter(0)), itemgetter(0)):
        values = [v for _, v in group if v is not None]
        if ch > 0 and values and ch not in formats:  # the logger's own format wins
            places[ch] = most_decimals(values)
    for ch, (time, value, name, unit) in _newest(db, logger, recent).items():
        old = out.get(ch)
        out[ch] = Channel(
            ch,
            (old.name if old and old.name else None) or name,
            (old.unit if old and old.unit else None) or unit,
            old.type if old else None,
            time,
            value,
        )
    for ch, n in (places | formats).items():
        if ch in out:
            out[ch] = replace(out[ch], decimals=n)
    return [out[k] for k in sorted(out)]


def _newest(db: Db, logger: str, recent: list[tuple[Any, ...]]) -> dict[int, tuple[Any, ...]]:
    """Per channel > 0 of the ``recent`` rows (``channel, value``, newest first), its newest
    row's time, value, name and unit: read again with its texts (they cost more, read for
    every recent row). On SQLite a query a channel (no round trips), on a server one
    statement (a round trip a channel took longer than the statement)."""
    d = db.dialect
    order = "ORDER BY time DESC, counter DESC"
    if d.postgres:
        every = d.query(
            "channel, time, counter, value, name, unit",
            "channel, time, counter, value, name, unit",
            "logger = ?",
            order=order,
            limit=True,
            positive=False,
        )
        return {
            row[0]: row[1:]
            for row in db.rows(
                f"SELECT channel, {d.time('time')}, value, name, unit FROM (SELECT *, "
                f"row_number() OVER (PARTITION BY channel {order}) AS nth FROM ({every}) r) w "
                "WHERE nth = 1 AND channel > 0",
                (logger, RECENT_ROWS),
            )
        }
    one = f"SELECT time, value, name, unit FROM readings WHERE logger = ? AND channel = ? {order}"
    return {
        ch: db.rows(one + " LIMIT 1", (logger, ch))[0]
        for ch in dict.fromkeys(map(itemgetter(0), recent))
        if ch > 0
    }


def format_decimals(form: str) -> int:
    """The decimals of a number format ``w.p`` (§4.3.5: ``p`` decimal places, §6.5.7):
    ``0.1`` -> 1, ``5.2`` -> 2, ``0.0`` -> 0."""
    _, _, places = form.strip().partition(".")
    return int(places) if places.isdigit() else 0


_FRACTION = re.compile(r"\.(\d+)")


def most_decimals(values: Sequence[float]) -> int:
    """``max(map(decimals, values))`` (``values`` not empty) with the digits read from all
    the values' text at once: a fraction of more than one digit is never ``0`` (the
    shortest text of a number ends in a digit other than 0 after its point)."""
    text = ",".join(map(repr, map(float, values)))
    if "e" in text:  # 1e-05, 1.5e+16: the rare values decimals() spells out
        return max(map(decimals, values))
    fractions = _FRACTION.findall(text)
    longest = max(map(len, fractions), default=0)
    if longest > 1:
        return min(longest, 6)
    return 1 if set(fractions) - {"0"} else 0


def decimals(value: float) -> int:
    """The decimals ``value`` shows at most (0 for a whole number; up to 6)."""
    text = repr(float(value))
    if "e" in text:
        text = f"{value:.6f}".rstrip("0")
    frac = text.partition(".")[2]
    return 0 if frac in ("", "0") else min(len(frac), 6)


def _end(db: Db, order: str) -> str:
    """The query of a logger's first (``order`` "") or last (" DESC") row's time."""
    d = db.dialect
    return f"SELECT {d.time('time')} FROM {d.keys} WHERE logger = ? ORDER BY time{order} LIMIT 1"


def last_time(db: Db, logger: str) -> str | None:
    row = db.first(_end(db, " DESC"), (logger,))
    return None if row is None else str(row[0])


def first_and_last(db: Db, logger: str) -> tuple[str | None, str | None]:
    """The time of the logger's first row and of its last, in one statement (one round
    trip)."""
    row = db.first(f"SELECT ({_end(db, '')}), ({_end(db, ' DESC')})", (logger, logger))
    if row is None:  # never: one row of two subqueries
        return None, None
    return row[0], row[1]


def counts(db: Db, logger: str, lo: str, hi: str, cap: int) -> tuple[dict[int, int], bool]:
    """Rows per channel in ``[lo, hi]``, counting at most ``cap`` rows in all.

    Returns the counts and whether the cap was reached (then the range holds more rows:
    no need to count a year of them to know it must be downsampled).
    """
    where = "logger = ? AND time >= ? AND time <= ?"
    some = db.dialect.query("channel", "channel", where, limit=True)
    got = {
        int(ch): int(n)
        for ch, n in db.rows(
            f"SELECT channel, count(*) FROM ({some}) r GROUP BY channel", (logger, lo, hi, cap)
        )
    }
    return got, sum(got.values()) >= cap


def reaches(db: Db, logger: str, lo: str, hi: str, cap: int) -> bool:
    """Whether ``[lo, hi]`` holds ``cap`` rows or more: whether it has a ``cap``-th (the
    rows before it skipped, not counted by channel: a long range's plot needs no more,
    :func:`counts` costs three times as much)."""
    where = "logger = ? AND time >= ? AND time <= ?"
    nth = db.dialect.query("1", "channel", where, limit=True) + " OFFSET ?"
    return db.first(nth, (logger, lo, hi, 1, cap - 1)) is not None


def raw(db: Db, logger: str, lo: str, hi: str) -> Iterator[tuple[str, int, int, float | None]]:
    """``(time, counter, channel, value)`` in ``[lo, hi]`` in time order."""
    d = db.dialect
    yield from db.rows(
        d.query(
            f"{d.time('time')}, counter, channel, value",
            "time, counter, channel, value",
            "logger = ? AND time >= ? AND time <= ?",
            order="ORDER BY time, counter",
        ),
        (logger, lo, hi),
    )


def bucketed(
    conn: sqlite3.Connection, logger: str, edges: Sequence[str]
) -> Iterator[tuple[int, int, int, float | None, str]]:
    """``(bucket, channel, which, value, time)`` for buckets ``[edges[i], edges[i+1])``:
    ``which`` 0 is the channel's smallest value in the bucket, 1 its largest, each with the
    time of a row that has it (SQLite takes a bare column from the row of a lone min/max).

    One key range per bucket and extreme: no function per row, and each bucket's grouping
    is small (measured faster than one joined query whose grouping sorts every row).

    The path of issue 14, on SQLite only: :mod:`.blocks` gives the same answers on either
    store, from the per-block extremes when the store has them (the tests compare both).
    """
    one = (
        "SELECT channel, {w}, {f}(value), time FROM readings WHERE logger = ? "
        "AND time >= ? AND time < ? AND channel > 0 GROUP BY channel"
    )
    q = one.format(w=0, f="min") + " UNION ALL " + one.format(w=1, f="max")
    for i in range(len(edges) - 1):
        lo, hi = edges[i], edges[i + 1]
        for ch, which, value, time in conn.execute(q, (logger, lo, hi, logger, lo, hi)):
            yield i, ch, which, value, time


def newer(db: Db, logger: str, since: str, limit: int) -> list[tuple[str, int, int, float | None]]:
    """``(time, counter, channel, value)`` at or after ``since``, oldest first."""
    d = db.dialect
    return db.rows(
        d.query(
            f"{d.time('time')}, counter, channel, value",
            "time, counter, channel, value",
            "logger = ? AND time >= ?",
            order="ORDER BY time, counter",
            limit=True,
        ),
        (logger, since, limit),
    )


def rows_for_csv(
    db: Db, logger: str, lo: str | None, hi: str | None, *, batch: int = 5000
) -> Iterator[tuple[Any, ...]]:
    """Every row of ``logger`` in ``[lo, hi]`` (open ends allowed) in the long-form CSV's
    :data:`~sondalog.collect.schema.COLUMNS`, the same as the download tool's; read in
    key-ordered pages of ``batch`` rows (a year is never held in memory at once)."""
    d = db.dialect
    spell = {"time": d.time("time"), "utc": d.utc("utc")}
    cols = ", ".join(spell.get(c, c) for c in COLUMNS)
    after: tuple[Any, ...] | None = None
    while True:
        q = f"SELECT {cols} FROM readings WHERE logger = ?"
        params: list[object] = [logger]
        if lo is not None:
            q += " AND time >= ?"
            params.append(lo)
        if hi is not None:
            q += " AND time <= ?"
            params.append(hi)
        if after is not None:  # the rows after the last one sent, by the key's order
            q += " AND (time > ? OR (time = ? AND (counter > ? OR (counter = ? AND channel > ?))))"
            params += [after[0], after[0], after[1], after[1], after[2]]
        page = db.rows(q + f" ORDER BY time, counter, channel LIMIT {int(batch)}", params)
        yield from page
        if len(page) < batch:
            return
        last = page[-1]
        after = tuple(last[COLUMNS.index(c)] for c in ("time", "counter", "channel"))


def events(db: Db, *, before: int | None, limit: int, source: str | None) -> list[dict[str, Any]]:
    """The newest ``limit`` events with ``id < before``, newest first."""
    q = "SELECT id, time, source, kind, text FROM events WHERE 1 = 1"
    params: list[object] = []
    if before is not None:
        q += " AND id < ?"
        params.append(before)
    if source:
        q += " AND source = ?"
        params.append(source)
    q += " ORDER BY id DESC LIMIT ?"
    params.append(limit)
    keys = ("id", "time", "source", "kind", "text")
    return [dict(zip(keys, row, strict=True)) for row in _file_rows(db, q, params)]

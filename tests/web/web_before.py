"""The dashboard's plot answer as it was made before issue 24's fifth round (the reference
the faster path is compared with, on random data: ``test_web_series_same.py``).

Verbatim copies of the old ``store.channels`` and ``store.counts``, ``series.load`` with its
downsampling, and ``blocks.rows`` (the per-block extremes merged bucket by bucket), over
today's unchanged pieces (``blocks.plan``, ``blocks.usable``, the statements of the ends);
:func:`body` is what the handler put together. The rows' path (``_by_rows`` and its
PostgreSQL statement) is the copy of the fifth round's, frozen here in the sixth when the
live one changed its statements and the shape of its rows.
"""

# ruff: noqa

from __future__ import annotations

import operator
from collections.abc import Iterator
from dataclasses import replace
from itertools import pairwise
from statistics import median
from typing import Any

from sondalog.web import blocks as _blocks
from sondalog.web.blocks import TABLE, Plan, Row, _span, _pair, SIZES, usable
from sondalog.web.series import Series, break_gaps
from sondalog.web.store import RECENT_ROWS, Channel, Db, _file_rows, decimals, format_decimals, raw
from sondalog.web.times import shift, to_epoch


def channels(db: Db, logger: str) -> list[Channel]:
    """The logger's channels with their last values, by channel number.

    From the optional ``channels`` table and the logger's newest :data:`RECENT_ROWS` rows.
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
    recent = db.rows(
        d.query(
            f"channel, {d.time('time')}, value, name, unit",
            "channel, time, counter, value, name, unit",
            "logger = ?",
            order="ORDER BY time DESC, counter DESC",
            limit=True,
            positive=False,
        ),
        (logger, RECENT_ROWS),
    )
    places: dict[int, int] = {}
    for ch, time, value, name, unit in recent:
        if ch <= 0:
            continue
        if value is not None and ch not in formats:  # the logger's own format wins
            places[ch] = max(places.get(ch, 0), decimals(value))
        old = out.get(ch)
        if old is not None and old.last_time is not None:
            continue
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


def load(
    db: Db,
    logger: str,
    chans: list[Channel],
    lo: str,
    hi: str,
    max_points: int,
) -> tuple[list[Series], float | None]:
    """The series of ``logger`` in ``[lo, hi]`` and the bucket width (None: not downsampled)."""
    by_ch = {c.channel: Series(c) for c in chans}
    # raw when every series has at most max_points rows; past this many rows in all, some
    # channel has more (pigeonhole), so counting stops there
    cap = max_points * max(1, len(by_ch)) + 1
    per_channel, capped = counts(db, logger, lo, hi, cap)
    for ch in per_channel:
        if ch not in by_ch:
            by_ch[ch] = Series(Channel(ch, None, None))
    largest = max(per_channel.values(), default=0)
    width: float | None = None
    if not capped and largest <= max_points:
        _raw(db, logger, lo, hi, by_ch)
        if all(len(s.t) <= max_points for s in by_ch.values()):
            return [by_ch[k] for k in sorted(by_ch)], None
        for s in by_ch.values():  # the gaps' nulls went over the budget
            s.t.clear()
            s.v.clear()
    width = _downsampled(db, logger, lo, hi, max_points // 2, by_ch)
    return [by_ch[k] for k in sorted(by_ch)], width


def _raw(db: Db, logger: str, lo: str, hi: str, by_ch: dict[int, Series]) -> None:
    prev_time = ""
    seen_in_second: dict[int, int] = {}
    base = 0
    for time, counter, ch, value in raw(db, logger, lo, hi):
        if time != prev_time:
            prev_time, base, seen_in_second = time, to_epoch(time), {}
        # rows written in the same second (counter > first) sit a millisecond apart
        slot = seen_in_second.setdefault(counter, len(seen_in_second))
        s = by_ch[ch]
        s.t.append(base + slot / 1000 if slot else base)
        s.v.append(value)
    for s in by_ch.values():
        s.step = break_gaps(s.t, s.v)


def _downsampled(
    db: Db,
    logger: str,
    lo: str,
    hi: str,
    buckets: int,
    by_ch: dict[int, Series],
) -> float:
    p = _blocks.plan(lo, hi, buckets)
    got = rows(db, logger, p)  # by channel and bucket
    start = 0
    while start < len(got):
        ch = got[start][1]
        end = start
        while end < len(got) and got[end][1] == ch:
            end += 1
        s = by_ch.setdefault(ch, Series(Channel(ch, None, None)))
        bars = s.channel.kind == "bars"
        t, v = s.t, s.v
        # a pause is broken only across an empty bucket, so the nulls keep within 2 per bucket
        jumps: list[int] = []
        last = got[start][0]
        for k, _, vmin, tmin, vmax, tmax in got[start:end]:
            # a bucket's points: its smallest and largest value at the times of readings that
            # have them, in time order (so every point lies in the range, where a reading
            # was); bars: the largest only
            if k - last > 1:
                jumps.append(len(t))
            last = k
            if bars or vmin == vmax:
                t.append(tmax)
                v.append(vmax)
            elif tmin == tmax:  # two rows of one second (counters): a millisecond apart
                t += (tmin, tmax + 0.001)
                v += (vmin, vmax)
            elif tmin < tmax:
                t += (tmin, tmax)
                v += (vmin, vmax)
            else:
                t += (tmax, tmin)
                v += (vmax, vmin)
        s.step = _break_at(t, v, jumps)
        start = end
    return float(p.width)


def _break_at(t: list[float], v: list[float | None], at: list[int]) -> float | None:
    """:func:`break_gaps` with ``may_break`` true only at the points ``at`` (few: the
    series' pauses), without going through every point again."""
    if len(t) < 3:
        return None
    usual: float = median(map(operator.sub, t[1:], t[:-1]))
    if usual <= 0:
        return None
    gaps = [i for i in at if t[i] - t[i - 1] > 3 * usual and v[i - 1] is not None]
    for i in reversed(gaps):
        t.insert(i, (t[i - 1] + t[i]) / 2)
        v.insert(i, None)
    return usual


def _ends(db: Db, p: Plan) -> tuple[str, list[object]]:
    """One statement of the two ends of ``p`` (before its first whole block, after its last:
    finer blocks and raw rows; ``k, ch, vmin, tmin, vmax, tmax``), and the parameters of
    its ``?`` other than the logger's (see :func:`_markers`); "" without ends."""
    pg = db.dialect.postgres
    args: list[object] = []
    parts = []
    finer = [s for s in SIZES if s < p.size]
    for k, lo, hi in ((0, p.edges[0], p.a), (p.m - 1, p.b, p.edges[-1])):
        if lo < hi:
            (smin, smax), more = _span(db, finer, lo, hi)
            parts.append(_pair(pg, smin, smax, "channel", str(k)))
            args += more + more
    return " UNION ALL ".join(f"SELECT * FROM ({x}) u{i}" for i, x in enumerate(parts)), args


def rows(db: Db, logger: str, p: Plan, *, use_blocks: bool | None = None) -> list[Row]:
    """``(bucket, channel, vmin, tmin, vmax, tmax)`` of the buckets of ``p`` by channel and
    bucket: the channel's smallest and largest value in the bucket, each with the earliest
    time (seconds) of a reading that has it (every value NULL: NULL and the latest time);
    from the blocks where they are complete (``use_blocks`` None) or when told, else from
    the rows (the same answer).

    From the blocks: one statement reads the whole blocks of the range (a year: 1,460 a
    channel), and each bucket's are merged here in time order (measured half the CPU of
    grouping them in SQL and reading the groups); one more reads the two ends."""
    blocks = usable(db, logger, p.edges[0]) if use_blocks is None else use_blocks
    if not (blocks and p.size):
        return _by_rows(db, logger, p)
    a, size, m, n = p.a, p.size, p.m, p.n
    per: dict[int, list[list[Any]]] = {}
    sql = (
        f"SELECT channel, start, vmin, tmin, vmax, tmax FROM {TABLE} WHERE logger = ? "
        "AND size = ? AND start >= ? AND start < ? ORDER BY start, channel"
    )
    got = db.conn.execute(db.dialect.sql(sql), (logger, size, a, p.b))
    if db.dialect.postgres:
        got = _chunks(got)
    for ch, start, vmin, tmin, vmax, tmax in got:
        k = (start - a) // size * m // n
        mine = per.get(ch)
        if mine is None:
            per[ch] = [[k, ch, vmin, tmin, vmax, tmax]]
            continue
        c = mine[-1]
        if c[0] != k:
            mine.append([k, ch, vmin, tmin, vmax, tmax])
            continue
        # the rule of _better, inlined (blocks in time order: a tie keeps the earlier)
        if vmin is not None:
            if c[2] is None or vmin < c[2]:
                c[2], c[3] = vmin, tmin
        elif c[2] is None:
            c[3] = tmin
        if vmax is not None:
            if c[4] is None or vmax > c[4]:
                c[4], c[5] = vmax, tmax
        elif c[4] is None:
            c[5] = tmax
    ends, args = _ends(db, p)
    if ends:
        rest = iter(args)  # every '?' is the logger's (``logger = ?``) or the next of args
        params = [logger if mine else next(rest) for mine in _markers(ends)]
        for row in db.conn.execute(db.dialect.sql(ends), params).fetchall():
            k, ch = row[0], row[1]
            mine = per.setdefault(ch, [])
            at = 0 if k == 0 else len(mine) - 1  # the first or the last bucket
            if mine and mine[at][0] == k:
                mine[at] = list(_both(tuple(mine[at]), row))
            else:
                mine.insert(0 if k == 0 else len(mine), list(row))
    return [tuple(r) for ch in sorted(per) for r in per[ch]]


def _chunks(cursor: Any, size: int = 2000) -> Iterator[Any]:
    """The rows of a psycopg ``cursor``, converted a chunk at a time: iterating the cursor
    runs Python code a row (most of a year's CPU in a profile), and fetching all 17,520
    rows at once kept them alive together (the garbage collector's passes over them cost
    as much again in the server's process)."""
    while chunk := cursor.fetchmany(size):
        yield from chunk


def _markers(sql: str) -> Iterator[bool]:
    """For each ``?`` of ``sql``: whether it is a logger's (``logger = ?``)."""
    parts = sql.split("?")
    for before in parts[:-1]:
        yield before.rstrip().endswith("logger =")


def _both(one: Row, two: Row) -> Row:
    """One bucket's extremes from two parts of it."""
    vmin, tmin = _better(0, (one[2], one[3]), (two[2], two[3]))
    vmax, tmax = _better(1, (one[4], one[5]), (two[4], two[5]))
    return one[0], one[1], vmin, tmin, vmax, tmax


def _better(
    which: int, old: tuple[float | None, int], new: tuple[float | None, int]
) -> tuple[float | None, int]:
    """The smallest (``which`` 0) or largest of two (value, time) of one bucket and channel
    by the rule of :func:`rows`."""
    (ov, ot), (nv, nt) = old, new
    if nv is None:
        return (ov, max(ot, nt)) if ov is None else old
    if ov is None:
        return new
    if nv == ov:
        return new if nt < ot else old
    return new if (nv < ov) == (which == 0) else old


def first_time(db: Db, logger: str) -> str | None:
    """The old ``store.first_time`` (the handler now asks ``store.first_and_last``)."""
    row = db.first(
        f"SELECT {db.dialect.time('time')} FROM {db.dialect.keys} WHERE logger = ? "
        "ORDER BY time LIMIT 1",
        (logger,),
    )
    return None if row is None else str(row[0])


def body(
    db: Db, logger: str, lo: str | None, hi: str | None, points: int, span: int
) -> dict[str, Any]:
    """The old handler's answer (``app.Api.series``'s ``work``)."""
    from sondalog.web import store

    last = store.last_time(db, logger)
    first = first_time(db, logger)
    to = hi or last or "1970-01-01T00:00:00"
    frm = lo or max(shift(to, -span), min(first or to, to))
    chans = channels(db, logger)
    got, width = load(db, logger, chans, frm, to, points)
    return {
        "logger": logger,
        "from": frm,
        "to": to,
        "x_from": to_epoch(frm),
        "x_to": to_epoch(to),
        "following": hi is None,
        "last": last,
        "first": first,
        "downsampled": width is not None,
        "bucket_s": width,
        "series": [s.as_json() for s in got],
    }


# The rows' path as it was at the end of the fifth round (verbatim).


def _by_rows(db: Db, logger: str, p: Plan) -> list[Row]:
    """The buckets of ``p`` from the rows: on PostgreSQL one statement over the range's
    rows (:func:`_by_rows_pg`); on SQLite one key range per bucket, one statement."""
    if db.dialect.postgres:
        return _by_rows_pg(db, logger, p)
    (smin, smax), _ = _span(db, (), 0, 1)
    texts = p.texts()
    out: list[Row] = []
    # the bucket a parameter: one text, compiled once (a text a bucket was compiled each
    # time, past the connection's cache of statements: most of a week's time)
    sql = db.dialect.sql(_pair(False, smin, smax, "channel", "?"))
    for i in range(len(texts) - 1):
        out += db.conn.execute(sql, [i, *[logger, texts[i], texts[i + 1]] * 2])
    out.sort(key=lambda r: (r[1], r[0]))
    return out


def _extreme(which: str) -> str:
    """PostgreSQL: a group's smallest (``min``) or largest ``v`` and its time ``t`` as an
    array ``[v, t]`` (``[v, -t]`` for the largest) of the reading that has it: arrays
    compare element by element, so on a tie the earliest time; NULL values left out."""
    t = "t" if which == "min" else "-t"
    return f"{which}(ARRAY[v, {t}]) FILTER (WHERE v IS NOT NULL)"


#: PostgreSQL: ``k, channel, vmin, tmin, vmax, tmax`` per bucket ``k`` and channel of one
#: logger's record rows in ``[lo, hi)`` (``{table}``, ``{k}`` a row's bucket, ``{t}`` its
#: time; ``{each}``: its readings, ``channel, v``). The rule of :func:`_pick` by aggregates
#: the server computes in one pass (a hash of the groups): the pair of the extreme's value
#: and time; every value NULL: NULL and the latest time. The bucket and the time are
#: computed once a record row (``OFFSET 0`` keeps them there), not once a reading.
_BUCKETS_PG = (
    f"SELECT k, channel, ({_extreme('min')})[1], coalesce(({_extreme('min')})[2]::bigint, "
    f"max(t)), ({_extreme('max')})[1], coalesce(-({_extreme('max')})[2]::bigint, max(t)) "
    "FROM (SELECT k, t, {each} FROM (SELECT {k} AS k, {t} AS t, channel, value FROM {table} "
    "WHERE logger = ? AND time >= ? AND time < ? OFFSET 0) r) u "
    "WHERE channel > 0 GROUP BY k, channel ORDER BY 2, 1"
)


def _bucket_of(p: Plan) -> tuple[str, list[object]]:
    """PostgreSQL: the bucket of ``p`` of a row (its whole second ``s``, as the ``time``
    comparisons of the rows' path count it) and the expression's parameters: equal buckets
    of ``p.width`` from ``edges[0]``, or blocks ``[a, b)`` ``n / m`` to a bucket and the
    ends to the first and last (as :func:`rows` puts the blocks)."""
    s = "floor(extract(epoch FROM time))::bigint"
    if not p.size:
        return f"({s} - ?::bigint) / ?::bigint", [p.edges[0], p.width]
    return (
        f"CASE WHEN {s} < ?::bigint THEN 0 WHEN {s} >= ?::bigint THEN ?::bigint "
        f"ELSE ({s} - ?::bigint) / ?::bigint * ?::bigint / ?::bigint END",
        [p.a, p.b, p.m - 1, p.a, p.size, p.m, p.n],
    )


def _by_rows_pg(db: Db, logger: str, p: Plan) -> list[Row]:
    """The buckets of ``p`` from the rows in one statement: each reading of the range is
    read once (a week of 12 channels: 121,000) with its record row's bucket (one range
    query a bucket, each sorting its readings, took about twice as long)."""
    d = db.dialect
    k, args = _bucket_of(p)
    v2 = d.keys != "readings"
    sql = _BUCKETS_PG.format(
        k=k,
        t=d.epoch("time"),
        table=d.keys,
        each="unnest(channel) AS channel, unnest(value) AS v" if v2 else "channel, value AS v",
    )
    texts = p.texts()
    return list(db.conn.execute(d.sql(sql), [*args, logger, texts[0], texts[-1]]).fetchall())

"""The plot's buckets of a long range and their extremes, from the per-block extremes the
sinks keep (:mod:`sondalog.collect.blocks_sql`, issue 24) or from the rows.

A plot of ``[lo, hi]`` in at most ``B`` buckets (:mod:`.series`) picks the coarsest block
size ``L`` (:data:`SIZES`) no longer than the range's ``B``-th part, and cuts the range on
the grid of ``L``: the whole blocks ``[a, b)`` inside it, ``n`` of them, go ``n / B`` (one or
more) to a bucket (block ``j`` to bucket ``j * m // n``, ``m = min(B, n)``), the part before
``a`` into the first bucket and the part after ``b`` into the last. So a bucket's extremes
are those of its whole blocks, and one statement reads them all (a year of 12 channels:
1,460 six-hour blocks a channel); the two ends (shorter than ``L``) are read as finer
blocks and raw rows in the same statement. Without a size that fits (a range under
``B`` half-hours) the buckets are ``B`` equal ones, as always.

What a bucket shows is the extremes of its rows, whichever way they are read: where a
logger's blocks are not complete yet (``readings_extremes_todo``: the rows stored before the
blocks were kept, filled in the background), or the store has none (an older collector's,
a read-only copy), the same buckets are read from the rows (slower; tested equal).
"""

from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from itertools import groupby, repeat
from operator import itemgetter
from typing import Any

from sondalog.collect.schema import EXTREMES as TABLE
from sondalog.collect.schema import EXTREMES_SIZES as SIZES
from sondalog.collect.schema import EXTREMES_TODO as TODO

from .db import Db
from .times import from_epoch, to_epoch

__all__ = ["SIZES", "Bucket", "Plan", "by_channel", "pieces", "plan"]

#: A bucket of the rows' path: ``(channel, bucket, vmin, tmin, vmax, tmax)``.
Row = tuple[int, int, float | None, int, float | None, int]
_RAW = "channel, time, value"


@dataclass(frozen=True, slots=True)
class Plan:
    """The buckets of one plot: ``edges`` (seconds; bucket ``i`` is ``[edges[i],
    edges[i + 1])``), their usual ``width``, and the blocks of ``size`` (0: none) that make
    them: ``[a, b)``, ``n`` blocks in ``m`` buckets."""

    edges: list[int]
    width: int
    size: int = 0
    a: int = 0
    b: int = 0
    n: int = 0

    @property
    def m(self) -> int:
        return len(self.edges) - 1

    def texts(self) -> list[str]:
        return [from_epoch(e) for e in self.edges]


def plan(lo: str, hi: str, buckets: int) -> Plan:
    """The buckets of ``[lo, hi]`` (whole seconds, ``hi`` included), at most ``buckets``."""
    start, end = to_epoch(lo), to_epoch(hi) + 1
    for size in reversed(SIZES):
        a, b = -(-start // size) * size, end // size * size
        n = (b - a) // size
        if size * buckets > end - start or n < 1:
            continue
        m = min(buckets, n)
        inner = [a + -(-k * n // m) * size for k in range(1, m)]
        return Plan([start, *inner, end], math.ceil((end - start) / m), size, a, b, n)
    width = max(1, math.ceil((end - start) / buckets))
    count = math.ceil((end - start) / width)
    return Plan([start + i * width for i in range(count + 1)], width)


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


def usable(db: Db, logger: str, since: int) -> bool:
    """Whether ``logger``'s blocks from ``since`` (seconds) on are complete."""
    if not db.has_blocks:
        return False
    row = db.first(f"SELECT below FROM {TODO} WHERE logger = ?", (logger,))
    return row is None or since >= int(row[0])


def _span(db: Db, sizes: Sequence[int], lo: int, hi: int) -> tuple[list[str], list[object]]:
    """Per extreme, the ``channel, v, t`` rows of ``[lo, hi)`` in time order, as blocks of
    ``sizes`` and raw rows at the ends; and the parameters (the logger first each time)."""
    arms: dict[str, list[str]] = {"min": [], "max": []}
    args: list[object] = []
    at = db.dialect.epoch("time")
    for size, p, q in pieces(lo, hi, sizes):
        if size == 0:
            sql = db.dialect.query(
                f"channel, value AS v, {at} AS t", _RAW, "logger = ? AND time >= ? AND time < ?"
            )
            args += [from_epoch(p), from_epoch(q)]
            for which in arms:
                arms[which].append(sql)
        else:  # the span's seconds parameters: a range's text is its sizes' (cached once)
            args += [p, q]
            for which in arms:
                arms[which].append(
                    f"SELECT channel, v{which} AS v, t{which} AS t FROM {TABLE} "
                    f"WHERE logger = ? AND size = {size} AND start >= ? AND start < ?"
                )
    return [" UNION ALL ".join(arms[w]) for w in ("min", "max")], args


def _pick(pg: bool, which: str, source: str, keys: str) -> str:
    """Per group of ``keys`` of ``source`` (rows of ``keys..., v, t`` in time order): its
    smallest (``which`` = ``min``) or largest ``v`` with the earliest ``t`` that has it, or,
    with every ``v`` NULL, NULL and the latest ``t`` (as :mod:`.dialect` says it for one
    channel: SQLite's bare column beside ``min``/``max``, PostgreSQL's ``DISTINCT ON``)."""
    if not pg:
        return f"SELECT {keys}, {which}(v) AS v, t FROM ({source}) GROUP BY {keys}"
    order = "" if which == "min" else " DESC"
    return (
        f"SELECT DISTINCT ON ({keys}) {keys}, v, t FROM ({source}) p ORDER BY {keys}, "
        f"v{order} NULLS LAST, CASE WHEN v IS NULL THEN t END DESC, t"
    )


def _pair(pg: bool, source_min: str, source_max: str, keys: str, k: str) -> str:
    """``k, ch, vmin, tmin, vmax, tmax`` per group of ``keys`` of the two sources (``keys...,
    v, t``, the candidates of each extreme); ``k`` the bucket's expression."""
    lo = _pick(pg, "min", source_min, keys)
    hi = _pick(pg, "max", source_max, keys)
    on = " AND ".join(f"a.{key.strip()} = b.{key.strip()}" for key in keys.split(","))
    return (
        f"SELECT {k} AS k, a.channel AS ch, a.v AS vmin, a.t AS tmin, b.v AS vmax, "
        f"b.t AS tmax FROM ({lo}) a JOIN ({hi}) b ON {on}"
    )


def _ends(db: Db, p: Plan) -> tuple[str, list[object]]:
    """One statement of the two ends of ``p`` (before its first whole block, after its last:
    finer blocks and raw rows; ``e, ch, vmin, tmin, vmax, tmax``, ``e`` 0 for the part before,
    1 for the part after), and the parameters of its ``?`` other than the logger's (see
    :func:`_markers`); "" without ends."""
    pg = db.dialect.postgres
    args: list[object] = []
    parts = []
    finer = [s for s in SIZES if s < p.size]
    for e, lo, hi in ((0, p.edges[0], p.a), (1, p.b, p.edges[-1])):
        if lo < hi:
            (smin, smax), more = _span(db, finer, lo, hi)
            parts.append(_pair(pg, smin, smax, "channel", str(e)))
            args += more + more
    return " UNION ALL ".join(f"SELECT * FROM ({x}) u{i}" for i, x in enumerate(parts)), args


def by_channel(
    db: Db, logger: str, p: Plan, *, use_blocks: bool | None = None
) -> Iterator[tuple[int, Iterator[Bucket]]]:
    """Per channel (once each, in no particular order) its buckets in order (a
    :data:`Bucket` each: the channel's smallest and largest value in the bucket, each with
    the earliest time, in seconds, of a reading that has it; every value NULL: NULL and the
    latest time), from the blocks where they are complete (``use_blocks`` None) or when
    told, else from the rows (the same answer); a channel's buckets are to be read before
    the next channel is asked for.

    From the blocks: one statement reads the whole blocks of the range (a year: 1,460 a
    channel) by channel and time, each with its bucket (on PostgreSQL worked out here:
    :func:`_blocks`), and a channel's blocks of one bucket are merged here as they come
    (:func:`_merged`); one more reads the two ends.
    On PostgreSQL a channel's blocks come as one row of arrays, in binary (psycopg makes
    the lists in C; a row a block, each converted by Python code, took most of a year's
    CPU)."""
    blocks = usable(db, logger, p.edges[0]) if use_blocks is None else use_blocks
    if not (blocks and p.size):
        yield from groupby(_by_rows(db, logger, p), _first)
        return
    ends: dict[int, list[Block | None]] = {}
    sql, args = _ends(db, p)
    if sql:
        rest = iter(args)  # every '?' is the logger's (``logger = ?``) or the next of args
        params = [logger if mine else next(rest) for mine in _markers(sql)]
        for e, ch, vmin, tmin, vmax, tmax in db.conn.execute(db.dialect.sql(sql), params):
            ends.setdefault(ch, [None, None])[e] = (e, e * (p.m - 1), vmin, tmin, vmax, tmax)
    where = "logger = ? AND size = ? AND start >= ? AND start < ?"
    if db.dialect.postgres:
        # grouped by a hash, the blocks' arrays in the order the server reads them (its
        # heap's: a sort by channel, by the key, or one an aggregate took the server two
        # to three times as long as the whole statement without); each channel's blocks
        # are sorted here by their starts unless these show them in order already
        # no array of the starts, nor of the buckets (each array took the server about
        # 3 ms): a block's tmin lies in it, so the tmins of a channel's blocks are in the
        # order of their starts, and give their buckets (:func:`_blocks`)
        arrays = ", ".join(f"array_agg({c})" for c in _EXTREMES)
        sql = (
            f"SELECT channel, {arrays} FROM (SELECT channel, {', '.join(_EXTREMES)} "
            f"FROM {TABLE} WHERE {where} {_KEY_ORDER}) b GROUP BY channel"
        )
        with db.conn.cursor(binary=True) as cur:
            got = cur.execute(db.dialect.sql(sql), [logger, p.size, p.a, p.b]).fetchall()
        whole: list[int] = []  # the buckets of all the blocks, once (the same for each channel)
        for ch, *columns in got:
            head, tail = ends.pop(ch, (None, None))
            yield ch, _merged(_blocks(ch, columns, p, whole), head, tail)
    else:
        # a block's bucket (``start >= a``: no negative division to round differently)
        k = "(start - ?) / ? * ? / ?"
        sql = f"SELECT channel, {k}, {', '.join(_EXTREMES)} FROM {TABLE} WHERE {where}"
        args = [p.a, p.size, p.m, p.n, logger, p.size, p.a, p.b]
        for ch, group in groupby(db.conn.execute(sql + " ORDER BY channel, start", args), _first):
            head, tail = ends.pop(ch, (None, None))
            yield ch, _merged(group, head, tail)  # (channel, k, ...): as a Block
    for ch, (head, tail) in ends.items():  # channels with readings at the ends only
        yield ch, _merged((), head, tail)


_EXTREMES = ("vmin", "tmin", "vmax", "tmax")
_first = itemgetter(0)
#: The order the server is asked to read the blocks in: none (a tests' knob: the answer is
#: the same in any order).
_KEY_ORDER = ""
#: One bucket's extremes after a column the reader does not look at (the channel, or
#: nothing): ``(_, bucket, vmin, tmin, vmax, tmax)``; the shape of a :data:`Block` and of
#: the rows' path's rows, so that a bucket of one block or one row is passed on as it is.
Bucket = tuple[Any, int, float | None, int, float | None, int]
#: A block's (or an end's) extremes with its bucket, after a column not read here (what
#: the statement gives first): ``(_, bucket, vmin, tmin, vmax, tmax)``.
Block = tuple[Any, int, float | None, int, float | None, int]


def _buckets(p: Plan, tmins: Sequence[int]) -> list[int]:
    """The bucket of each block whose tmin (a time in the block) is in ``tmins``."""
    a, size, m, n = p.a, p.size, p.m, p.n
    return [(t - a) // size * m // n for t in tmins]


def _blocks(ch: int, columns: list[Sequence[Any]], p: Plan, whole: list[int]) -> Iterable[Block]:
    """One channel's blocks (``columns``: its vmins, tmins, vmaxs and tmaxs, in any order)
    as :data:`Block` tuples in time order: ``n`` of them are every block of ``p`` (block
    ``j`` in bucket ``j * m // n``, kept in ``whole``), fewer have theirs from their tmins."""
    tmins = columns[1]
    if not all(map(operator.lt, tmins, tmins[1:])):  # the order of their starts
        order = sorted(range(len(tmins)), key=tmins.__getitem__)
        columns = [[c[i] for i in order] for c in columns]
        tmins = columns[1]
    if len(tmins) != p.n:
        return zip(repeat(ch), _buckets(p, tmins), *columns)
    if not whole:
        whole += [j * p.m // p.n for j in range(p.n)]
    return zip(repeat(ch), whole, *columns)


def _merged(got: Iterable[Block], head: Block | None, tail: Block | None) -> Iterator[Bucket]:
    """One channel's buckets of its blocks ``got`` (in time order), with ``head`` (the first
    bucket's end) before them and ``tail`` (the last's) after: the blocks of one bucket
    merged by the rule of :func:`by_channel` (in time order, so on a tie the one before
    stays, and every value NULL takes the later time). A bucket of one block is that block
    (no new tuple)."""
    it = itertools.chain(got, () if tail is None else (tail,))
    if head is None:
        head = next(it, None)
        if head is None:
            return
    cur = head
    for block in it:
        if block[1] != cur[1]:
            yield cur
            cur = block
            continue
        _, ck, cmin, ctmin, cmax, ctmax = cur
        _, _, vmin, tmin, vmax, tmax = block
        if vmin is not None:
            if cmin is None or vmin < cmin:
                cmin, ctmin = vmin, tmin
        elif cmin is None:
            ctmin = tmin
        if vmax is not None:
            if cmax is None or vmax > cmax:
                cmax, ctmax = vmax, tmax
        elif cmax is None:
            ctmax = tmax
        cur = (None, ck, cmin, ctmin, cmax, ctmax)
    yield cur


def _markers(sql: str) -> Iterator[bool]:
    """For each ``?`` of ``sql``: whether it is a logger's (``logger = ?``)."""
    parts = sql.split("?")
    for before in parts[:-1]:
        yield before.rstrip().endswith("logger =")


def _by_rows(db: Db, logger: str, p: Plan) -> list[Row]:
    """The buckets of ``p`` from the rows (``channel, k, vmin, tmin, vmax, tmax`` by
    channel and bucket): on PostgreSQL one statement over the range's
    rows (:func:`_by_rows_pg`); on SQLite one key range per bucket, one statement."""
    if db.dialect.postgres:
        return _by_rows_pg(db, logger, p)
    texts = p.texts()
    out: list[Row] = []
    execute = db.conn.execute
    # the bucket a parameter: one text, compiled once (a text a bucket was compiled each
    # time, past the connection's cache of statements: most of a week's time)
    for i in range(len(texts) - 1):
        out += execute(_BUCKET_SQLITE, [i, *[logger, texts[i], texts[i + 1]] * 2])
    out.sort(key=_first)  # by channel; each channel's buckets stay in order (a stable sort)
    return out


def _extreme_sqlite(which: str) -> str:
    """SQLite: per channel of one bucket's rows its smallest (``min``) or largest value
    and, as a bare column beside the lone aggregate, the time of the row that has it (as
    :func:`_pick` says; the text time, its seconds taken of the one row it ends up as)."""
    return (
        f"SELECT channel, {which}(value) AS v, time AS t FROM readings WHERE logger = ? "
        "AND time >= ? AND time < ? AND channel > 0 GROUP BY channel"
    )


#: SQLite: ``channel, k, vmin, tmin, vmax, tmax`` of bucket ``k`` (the first parameter) of
#: one logger's rows in ``[lo, hi)``: :func:`_pair` over the rows, with ``unixepoch`` worked
#: out for the two rows chosen of each channel, not for every row read (twice).
_BUCKET_SQLITE = (
    "SELECT a.channel, ? AS k, a.v, unixepoch(a.t), b.v, unixepoch(b.t) "
    f"FROM ({_extreme_sqlite('min')}) a JOIN ({_extreme_sqlite('max')}) b "
    "ON a.channel = b.channel"
)


def _extreme(which: str) -> str:
    """PostgreSQL: a group's smallest (``min``) or largest ``v`` and its time ``t`` as an
    array ``[v, t]`` (``[v, -t]`` for the largest) of the reading that has it: arrays
    compare element by element, so on a tie the earliest time; NULL values left out."""
    t = "t" if which == "min" else "-t"
    return f"{which}(ARRAY[v, {t}]) FILTER (WHERE v IS NOT NULL)"


#: PostgreSQL: ``channel, k, vmin, tmin, vmax, tmax`` per bucket ``k`` and channel of one
#: logger's record rows in ``[lo, hi)`` (``{table}``, ``{k}`` a row's bucket, ``{t}`` its
#: time; ``{each}``: its readings, ``channel, v``). The rule of :func:`_pick` by aggregates
#: the server computes in one pass (a hash of the groups): the pair of the extreme's value
#: and time; every value NULL: NULL and the latest time. The bucket and the time are
#: computed once a record row (``OFFSET 0`` keeps them there), not once a reading.
_BUCKETS_PG = (
    f"SELECT channel, k, ({_extreme('min')})[1], coalesce(({_extreme('min')})[2]::bigint, "
    f"max(t)), ({_extreme('max')})[1], coalesce(-({_extreme('max')})[2]::bigint, max(t)) "
    "FROM (SELECT k, t, {each} FROM (SELECT {k} AS k, {t} AS t, channel, value FROM {table} "
    "WHERE logger = ? AND time >= ? AND time < ? OFFSET 0) r) u "
    "WHERE channel > 0 GROUP BY k, channel ORDER BY 1, 2"
)


def _bucket_of(p: Plan) -> tuple[str, list[object]]:
    """PostgreSQL: the bucket of ``p`` of a row (its whole second ``s``, as the ``time``
    comparisons of the rows' path count it) and the expression's parameters: equal buckets
    of ``p.width`` from ``edges[0]``, or blocks ``[a, b)`` ``n / m`` to a bucket and the
    ends to the first and last (as :func:`by_channel` puts the blocks)."""
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

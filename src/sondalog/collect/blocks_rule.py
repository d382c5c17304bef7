"""The rule by which a block of the dashboard's extremes takes new ones (issue 24), in
Python (:func:`take`, :func:`aggregate`: a batch's blocks; :func:`aggregate_rows`: the same
from its record rows, by column) and in SQL (:data:`MERGE`: the same rule on SQLite and
PostgreSQL), for :mod:`.blocks_sql`; :class:`Written`: the blocks a sink knows stored, which
it need not send again.

A smaller (``vmin``) or larger (``vmax``) value wins; on a tie the earlier time; NULL loses
to any value, and between NULLs the later time wins.
"""

from __future__ import annotations

import itertools
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from datetime import UTC, datetime
from typing import Any

from sondalog.collect.model import Reading
from sondalog.collect.schema import EXTREMES, EXTREMES_SIZES

SIZES = EXTREMES_SIZES
TABLE = EXTREMES


def _merge(v: str, t: str, better: str) -> str:
    """``SET`` of one extreme: the stored block takes the new one (``excluded``) when its
    value is ``better`` (``<``, ``>``), and on a tie the earlier time; NULL values lose to
    any value, and between blocks of NULLs only the later time wins."""
    old_v, old_t = f"{TABLE}.{v}", f"{TABLE}.{t}"
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


def _changes(v: str, t: str, better: str) -> str:
    """When :func:`_merge` changes the stored extreme: exactly its branches that take a new
    value or time (a value, NULL or not, that is not better keeps the stored block)."""
    old_v, old_t = f"{TABLE}.{v}", f"{TABLE}.{t}"
    new_v, new_t = f"excluded.{v}", f"excluded.{t}"
    return (
        f"({new_v} IS NULL AND {old_v} IS NULL AND {new_t} > {old_t}) OR ({new_v} IS NOT NULL "
        f"AND ({old_v} IS NULL OR {new_v} {better} {old_v} OR "
        f"({new_v} = {old_v} AND {new_t} < {old_t})))"
    )


#: How a stored block takes new extremes; the same SQL on both servers. A block that keeps
#: both extremes is not written at all (most coarse blocks, batch after batch: an update
#: that changes nothing still writes a new row version and its index entry).
MERGE = (
    _merge("vmin", "tmin", "<")
    + ", "
    + _merge("vmax", "tmax", ">")
    + f" WHERE {_changes('vmin', 'tmin', '<')} OR {_changes('vmax', 'tmax', '>')}"
)
REPLACE = "vmin = excluded.vmin, tmin = excluded.tmin, vmax = excluded.vmax, tmax = excluded.tmax"
CONFLICT = "ON CONFLICT (logger, size, start, channel) DO UPDATE SET "


def epoch(at: datetime) -> int:
    return int(at.replace(tzinfo=UTC).timestamp())


def take(c: list[Any], v: float | None, t: int, at: int, better: int) -> bool:
    """``c[at], c[at + 1]`` (value, time) take ``(v, t)`` by the rule of the blocks (a
    smaller, ``better`` -1, or larger value; on a tie the earlier time; NULL loses, and
    between NULLs the later time); True when they changed."""
    old = c[at]
    if v is None:
        if old is None and t > c[at + 1]:
            c[at + 1] = t
            return True
        return False
    if old is None or (v - old) * better > 0 or (v == old and t < c[at + 1]):
        c[at], c[at + 1] = v, t
        return True
    return False


def aggregate(batch: Iterable[Reading]) -> list[tuple[Any, ...]]:
    """The blocks of every size of ``batch``'s readings (channels > 0) as rows of the table:
    exact for a batch whose every row was stored (none ignored as a duplicate)."""
    fine: dict[tuple[str, int, int], list[Any]] = {}
    size = SIZES[0]
    last: datetime | None = None
    sec = start = 0
    for r in batch:
        if r.channel <= 0:
            continue
        if r.time != last:
            last, sec = r.time, epoch(r.time)
            start = sec - sec % size
        _add(fine, (r.logger, start, r.channel), r.value, sec)
    return _coarser(fine)


def _add(fine: dict[tuple[str, int, int], list[Any]], key: Any, v: Any, sec: int) -> None:
    """One reading into its finest block."""
    c = fine.get(key)
    if c is None:
        fine[key] = [v, sec, v, sec]
    elif v is not None and c[0] is not None and c[2] is not None:  # take, inlined
        if v < c[0] or (v == c[0] and sec < c[1]):
            c[0], c[1] = v, sec
        if v > c[2] or (v == c[2] and sec < c[3]):
            c[2], c[3] = v, sec
    else:
        take(c, v, sec, 0, -1)
        take(c, v, sec, 2, 1)


def _coarser(fine: dict[tuple[str, int, int], list[Any]]) -> list[tuple[Any, ...]]:
    """The finest blocks as rows of the table, and the blocks of every coarser size (each
    from the finest, in their order; :func:`take` inlined where neither value is NULL, as in
    :func:`_add`)."""
    out = [(lg, SIZES[0], st, ch, *c) for (lg, st, ch), c in fine.items()]
    for coarse in SIZES[1:]:
        blocks: dict[tuple[str, int, int], list[Any]] = {}
        for (lg, st, ch), c in fine.items():
            key = (lg, st - st % coarse, ch)
            b = blocks.get(key)
            if b is None:
                blocks[key] = [*c]
                continue
            v, old = c[0], b[0]
            if v is None or old is None:
                take(b, v, c[1], 0, -1)
            elif v < old or (v == old and c[1] < b[1]):
                b[0], b[1] = v, c[1]
            v, old = c[2], b[2]
            if v is None or old is None:
                take(b, v, c[3], 2, 1)
            elif v > old or (v == old and c[3] < b[3]):
                b[2], b[3] = v, c[3]
        out += [(lg, coarse, st, ch, *c) for (lg, st, ch), c in blocks.items()]
    return out


def aggregate_rows(rows: Sequence[tuple[Any, ...]]) -> list[tuple[Any, ...]]:
    """:func:`aggregate` of the readings of record ``rows`` as :func:`sondalog.collect.
    pg_rows.group` makes them (``logger, time, counter, utc, channels, types, values, ...``;
    channels rising), by column: the rows of one logger and finest block, of the same
    channels and in time order, give each channel's extremes by ``min``/``max`` and ``index``
    (the first, so the earliest time, as the rule wants on a tie); other rows (NULLs, out of
    time order or of other channels) go reading by reading. With a NaN anywhere (which the
    rule orders nowhere, so the order met counts) every reading goes in the rows' order.
    (:class:`Aggregate` takes the rows a piece at a time.)"""
    whole = Aggregate()
    whole.add(rows)
    return whole.blocks()


class Aggregate:
    """:func:`aggregate_rows` of rows given a piece at a time (:meth:`add`), taken into the
    finest blocks :attr:`AT_ONCE` rows at a time (the PostgreSQL sink's pieces are smaller:
    a batch's blocks are mostly computed at the end, while the server stores the last
    pieces); :meth:`blocks` at the end. Exact: a finest block's extremes from two takes are
    merged by the rule (:func:`take`), which without NaN gives what the rows together give
    in any order; with a NaN in any take every reading goes in the rows' order at the end."""

    #: Record rows taken into the finest blocks at a time: fewer rows a block and channel
    #: cost more Python a reading (each block's channels by ``min``/``max``).
    AT_ONCE = 1_024

    def __init__(self) -> None:
        self._fine: dict[tuple[str, int, int], list[Any]] = {}
        self._seconds: dict[datetime, int] = {}
        self._rows: list[tuple[Any, ...]] = []
        self._done = 0  # rows taken into the finest blocks so far
        self._nan = False

    def add(self, rows: Sequence[tuple[Any, ...]]) -> None:
        """The next rows (all of a record row's readings in one piece)."""
        self._rows += rows
        if len(self._rows) - self._done >= self.AT_ONCE:
            self._take()

    def _take(self) -> None:
        """The rows not yet taken into the finest blocks, taken."""
        if not self._nan:
            rows = self._rows[self._done :]
            self._nan = not _fine_of(rows, self._seconds, self._fine)
        self._done = len(self._rows)

    def blocks(self) -> list[tuple[Any, ...]]:
        """The blocks of every size of all the rows added (as :func:`aggregate_rows`)."""
        self._take()
        if self._nan:
            return _by_reading(self._rows, self._seconds)
        return _coarser(self._fine)


def _fine_of(
    rows: Sequence[tuple[Any, ...]],
    seconds: dict[datetime, int],
    fine: dict[tuple[str, int, int], list[Any]],
) -> bool:
    """The finest blocks of ``rows`` merged into ``fine`` by column (:func:`aggregate_rows`);
    False, ``fine`` then unfinished, at a NaN."""
    size = SIZES[0]
    blocks: dict[tuple[str, int], tuple[list[int], list[tuple[Any, ...]]]] = {}
    for r in rows:
        sec = seconds.get(r[1])
        if sec is None:
            sec = seconds[r[1]] = epoch(r[1])
        block = blocks.get((r[0], sec - sec % size))
        if block is None:
            blocks[r[0], sec - sec % size] = ([sec], [r])
        else:
            block[0].append(sec)
            block[1].append(r)
    try:  # one sum for the rows: no NULL (TypeError) and no NaN (nor both infinities)
        total = sum(itertools.chain.from_iterable([r[6] for r in rows]))
        clean = total == total
    except TypeError:
        clean = False
    for (lg, start), (secs, got) in blocks.items():
        channels = got[0][4]
        if [r[4] for r in got].count(channels) != len(got):
            slow = [
                (sec, ch, v)
                for sec, r in zip(secs, got, strict=True)
                for ch, v in zip(r[4], r[6], strict=True)
            ]
            if any(v != v for _, _, v in slow):
                return False
            for sec, ch, v in slow:
                if ch > 0:
                    _add(fine, (lg, start, ch), v, sec)
            continue
        ordered = secs == sorted(secs)
        columns = zip(channels, zip(*[r[6] for r in got], strict=True), strict=True)
        if clean and ordered:  # the common case: no test a column
            for ch, col in columns:
                if ch > 0:
                    lo, hi = min(col), max(col)
                    _extremes(
                        fine, (lg, start, ch), lo, secs[col.index(lo)], hi, secs[col.index(hi)]
                    )
            continue
        for ch, col in columns:
            if ch <= 0:
                continue
            key = (lg, start, ch)
            if None in col:
                if any(v != v for v in col):
                    return False
                for v, sec in zip(col, secs, strict=True):
                    _add(fine, key, v, sec)
            elif (total := sum(col)) != total:  # NaN (or both infinities)
                return False
            elif not ordered:
                for v, sec in zip(col, secs, strict=True):
                    _add(fine, key, v, sec)
            else:
                lo, hi = min(col), max(col)
                _extremes(fine, key, lo, secs[col.index(lo)], hi, secs[col.index(hi)])
    return True


def _extremes(
    fine: dict[tuple[str, int, int], list[Any]], key: Any, lo: Any, t_lo: int, hi: Any, t_hi: int
) -> None:
    """A finest block's extremes of some of its rows (no NULL, no NaN) into ``fine``: merged
    by the rule with those of other rows (another piece) if there are some."""
    c = fine.get(key)
    if c is None:
        fine[key] = [lo, t_lo, hi, t_hi]
    else:
        take(c, lo, t_lo, 0, -1)
        take(c, hi, t_hi, 2, 1)


def _by_reading(rows: Sequence[tuple[Any, ...]], seconds: dict[datetime, int]) -> list[Any]:
    """:func:`aggregate_rows` reading by reading, in the rows' order (as :func:`aggregate`)."""
    fine: dict[tuple[str, int, int], list[Any]] = {}
    size = SIZES[0]
    for r in rows:
        sec = seconds.get(r[1])
        if sec is None:
            sec = seconds[r[1]] = epoch(r[1])
        for ch, v in zip(r[4], r[6], strict=True):
            if ch > 0:
                _add(fine, (r[0], sec - sec % size, ch), v, sec)
    return _coarser(fine)


def _beats(v: float | None, t: int, old_v: float | None, old_t: int, better: int) -> bool:
    """Whether ``(v, t)`` replaces ``(old_v, old_t)`` by the rule (exactly :data:`MERGE`'s
    ``WHERE``: a smaller, ``better`` -1, or larger value; on a tie the earlier time; NULL
    loses, and between NULLs the later time)."""
    if v is None:
        return old_v is None and t > old_t
    if old_v is None:
        return True
    return (v < old_v if better < 0 else v > old_v) or (v == old_v and t < old_t)


class Written:
    """The blocks a sink knows to be stored at least this good (bounded): a block of a new
    batch that would not change them is not sent (issue 24: most coarse blocks, batch after
    batch, cost the server a key look-up and a row lock for nothing).

    Sound because a stored block only ever takes better extremes (:data:`MERGE`; the coarse
    blocks made again from the finer ones, :data:`REPLACE`, hold what those hold): what was
    committed is a lower bound of what is stored for good. Noted only after the commit
    (:meth:`note`); emptied by the sink whenever it connects (a server restored from a
    backup, or another one behind the same name, may hold less). NaN (which PostgreSQL
    orders above every number, Python nowhere) is always sent."""

    #: Blocks remembered, the least recently written forgotten first (about 400 bytes each,
    #: 3.3 MB in all; a batch of 20 loggers of 8 channels keeps about 1,000 current).
    LIMIT = 8_192

    def __init__(self) -> None:
        # Ordered by the last write; an OrderedDict finds its first key at once (a dict's
        # ``next(iter())`` goes past the places of every key deleted before it: thousands,
        # block after block, measured 0.2 us a reading of a batch).
        self._known: OrderedDict[tuple[Any, ...], tuple[Any, ...]] = OrderedDict()

    def __len__(self) -> int:
        return len(self._known)

    def clear(self) -> None:
        self._known.clear()

    def changing(self, blocks: Iterable[tuple[Any, ...]]) -> list[tuple[Any, ...]]:
        """The ``blocks`` (rows of the table, as :func:`aggregate`'s) that may change the
        stored ones: unknown, or better in an extreme than what is known (:func:`_beats`,
        inlined where no value is NULL)."""
        known = self._known
        out: list[tuple[Any, ...]] = []
        add = out.append
        for b in blocks:
            old = known.get(b[:4])
            if old is None:
                add(b)
                continue
            lo, hi, old_lo, old_hi = b[4], b[6], old[0], old[2]
            if lo is None or hi is None or old_lo is None or old_hi is None:
                if (
                    lo != lo  # NaN (NULL: None == None)
                    or hi != hi
                    or _beats(lo, b[5], old_lo, old[1], -1)
                    or _beats(hi, b[7], old_hi, old[3], 1)
                ):
                    add(b)
            elif (
                lo < old_lo
                or hi > old_hi
                or lo != lo  # NaN
                or hi != hi
                or (lo == old_lo and b[5] < old[1])
                or (hi == old_hi and b[7] < old[3])
            ):
                add(b)
        return out

    def note(self, blocks: Iterable[tuple[Any, ...]]) -> None:
        """``blocks`` are committed: each known block takes them by the rule."""
        known = self._known
        for b in blocks:
            key = b[:4]
            old = known.pop(key, None)
            c = list(b[4:])
            if old is not None:
                c = list(old)
                take(c, b[4], b[5], 0, -1)
                take(c, b[6], b[7], 2, 1)
            if c[0] == c[0] and c[2] == c[2]:  # NaN is not remembered: always sent
                known[key] = tuple(c)
                if len(known) > self.LIMIT:
                    known.popitem(last=False)

"""A batch of readings as PostgreSQL record rows, and their binary ``COPY`` (schema version 2).

:func:`group` gathers a batch's readings by ``(logger, time, counter)``, one record row each
(:data:`sondalog.collect.schema_pg.COLUMNS`: the key, ``utc`` and the channels' parallel
arrays ordered by channel). A reading seen twice in a batch (the same channel of the same
row) is kept once, the first; a row's channels spread over the batch are merged.
:func:`pieces` does it a piece of the batch at a time (the sink sends one while it makes the
next); :func:`split` shares a batch out between writer connections.

:func:`encode` writes rows in PostgreSQL's binary ``COPY`` format (the signature, each row's
fields, the trailer) straight with :mod:`struct`: psycopg's array dumpers are Python per
element, and most of a row's arrays (channels, types, names, units, texts) are the same row
after row, so they are encoded once and looked up (:class:`Encoder`). NUL characters, which
PostgreSQL text cannot hold, are dropped here.
"""

from __future__ import annotations

import array
import itertools
import operator
import struct
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from datetime import UTC, datetime, timedelta
from typing import Any, TypeVar, cast

from sondalog.collect.model import Reading

#: One record row: logger, time, counter, utc, then the arrays channel, type, value, text,
#: name, unit (tuples, one element a reading, ordered by channel).
Row = tuple[str, datetime, int, datetime | None, tuple[int, ...], tuple[int, ...],
            tuple[float | None, ...], tuple[str | None, ...], tuple[str | None, ...],
            tuple[str | None, ...]]  # fmt: skip

_fields = operator.attrgetter(
    "logger", "time", "counter", "channel", "type", "value", "text", "name", "unit", "utc"
)
_key = operator.attrgetter("logger", "time", "counter")
_cells = operator.attrgetter("channel", "type", "value", "text", "name", "unit")
_channel = operator.itemgetter(3)
_row_key = operator.itemgetter(0, 1, 2)  # a record row's logger, time, counter
T = TypeVar("T")


def _merged(cells: list[tuple[Any, ...]]) -> Row:
    """The row of one key's readings (their :data:`_fields`) that are not in channel order,
    or hold a channel twice (the first kept)."""
    first: dict[int, tuple[Any, ...]] = {}
    for c in cells:
        first.setdefault(c[3], c)
    ordered = sorted(first.values(), key=_channel)
    _, _, _, ch, ty, va, tx, na, un, _ = zip(*ordered, strict=True)
    c0 = cells[0]
    return (c0[0], c0[1], c0[2], c0[9], ch, ty, va, tx, na, un)


def group(batch: Iterable[Reading]) -> list[Row]:
    """The record rows of ``batch`` in the order their first readings come.

    A row's readings are usually next to each other, in channel order (a logger's record
    row as read): then the batch is taken by column (:func:`by_column`); otherwise a run of
    one key at a time, transposed by ``zip``, any other order merged (:func:`by_run`)."""
    batch = batch if isinstance(batch, list) else list(batch)
    rows = by_column(batch)
    return by_run(batch) if rows is None else rows


def by_column(batch: list[Reading]) -> list[Row] | None:
    """:func:`by_run` of a batch whose every record row is one run of readings in rising
    channel order, a run's key met once (the readings as a logger's rows are read); None
    for any other batch.

    A column at a time, one step a row besides (issue 24: :func:`by_run` takes each
    reading's attributes by ``attrgetter``, about a third of the collector's CPU on
    PostgreSQL; a comprehension reads a slot about twice as fast): where the runs of one
    key start (:func:`_starts`), each column cut there (rows all of one length by ``zip``
    of one iterator, in C)."""
    n = len(batch)
    if not n:
        return []
    starts, heads, k = _starts(batch)
    if len(set(heads)) != len(heads):
        return None  # a row's readings in two runs
    if k:

        def cut(column: list[Any]) -> list[tuple[Any, ...]]:
            return list(zip(*[iter(column)] * k, strict=True))

    else:
        ends = [*starts[1:], n]

        def cut(column: list[Any]) -> list[tuple[Any, ...]]:
            return [tuple(column[s:e]) for s, e in zip(starts, ends, strict=True)]

    ch = cut([r.channel for r in batch])
    ordered = _ORDERED
    for c in set(ch):
        if not (ordered.get(c) or _in_order(c)):
            return None
    ty = cut([r.type for r in batch])
    va = cut([r.value for r in batch])
    tx = cut([r.text for r in batch])
    na = cut([r.name for r in batch])
    un = cut([r.unit for r in batch])
    utc = [batch[s].utc for s in starts]
    return [
        (h[0], h[1], h[2], u, c, t, v, x, m, w)
        for h, u, c, t, v, x, m, w in zip(heads, utc, ch, ty, va, tx, na, un, strict=True)
    ]


def _starts(batch: list[Reading]) -> tuple[Sequence[int], list[tuple[str, datetime, int]], int]:
    """Where the runs of one key (logger, time, counter) of ``batch`` start, their keys, and
    their length when all have one (else 0). Runs of one length ``k`` (a batch of rows of
    the same channels) are found by comparing the key columns with themselves shifted by
    ``k`` (C loops, elements mostly the same objects); any others by comparing each key
    with the next (``map(ne)``). Equality as :func:`itertools.groupby`'s."""
    n = len(batch)
    lg = [r.logger for r in batch]
    tm = [r.time for r in batch]
    cn = [r.counter for r in batch]
    k = 1
    while k < n and lg[k] == lg[0] and tm[k] == tm[0] and cn[k] == cn[0]:
        k += 1
    if n % k == 0:
        columns: list[list[Any]] = [lg, tm, cn]
        heads = [c[::k] for c in columns]
        if all(c[j::k] == h for c, h in zip(columns, heads, strict=True) for j in range(1, k)):
            keys = list(zip(*heads, strict=True))
            if all(map(operator.ne, keys, keys[1:])):  # else a run of 2k, 3k...
                return range(0, n, k), keys, k
    keys = list(zip(lg, tm, cn, strict=True))
    starts = [0, *itertools.compress(itertools.count(1), map(operator.ne, keys, keys[1:]))]
    return starts, [keys[s] for s in starts], 0


def by_run(batch: Iterable[Reading]) -> list[Row]:
    """:func:`group` a run of readings of one key at a time (the way of any batch)."""
    out: list[Row] = []
    where: dict[tuple[str, datetime, int], int] = {}
    apart: dict[int, list[tuple[Any, ...]]] = {}  # rows whose readings came apart
    ordered = _ORDERED
    rising: tuple[int, ...] = ()  # the last channels known in order (compared, not hashed)
    for key, run in itertools.groupby(batch, key=_key):
        got = list(run)
        n = len(out)
        if where.setdefault(key, n) != n:
            apart.setdefault(where[key], [*_cells_of(out[where[key]])]).extend(map(_fields, got))
            continue
        ch, ty, va, tx, na, un = zip(*map(_cells, got), strict=False)  # six each: equal
        if ch != rising:
            if not (ordered.get(ch) or _in_order(ch)):
                out.append(_merged(list(map(_fields, got))))
                continue
            rising = ch
        out.append((key[0], key[1], key[2], got[0].utc, ch, ty, va, tx, na, un))
    for at, cells in apart.items():
        out[at] = _merged(cells)
    return out


def pieces(batch: Sequence[Reading], size: int) -> Iterator[list[Row]]:
    """:func:`group` of ``batch`` a piece of about ``size`` readings at a time (each cut
    at the end of a run of one key), so that a piece can be sent while the next is made;
    the first a quarter of that (the server starts sooner).

    Raises :class:`Apart` at the first piece holding a row of an earlier piece (the
    caller's rows sent so far are then incomplete: it starts again with :func:`group`)."""
    sent: set[tuple[str, datetime, int]] = set()
    start, step = 0, max(1, size // 4)
    while start < len(batch):
        end = min(start + step, len(batch))
        step = size
        if end < len(batch):
            last = _key(batch[end - 1])
            while end < len(batch) and _key(batch[end]) == last:
                end += 1
        rows = group(batch[start:end])
        known = len(sent)
        sent.update(map(_row_key, rows))  # a piece's keys are distinct (group): each hashed once
        if len(sent) != known + len(rows):
            raise Apart
        yield rows
        start = end


class Apart(Exception):
    """A record row's readings are in two pieces of a batch (:func:`pieces`)."""


_logger = operator.attrgetter("logger")


def split(
    batch: Sequence[T], n: int, logger: Callable[[T], str] = _logger
) -> Sequence[Sequence[T]]:
    """``batch`` (readings, or record rows with ``logger`` their logger) in at most ``n``
    parts of similar size: by logger when that shares it out well (each part's rows then go
    to other places of the primary key than the other parts', so their servers do not wait
    for each other's pages), else in ``n`` slices."""
    if n <= 1:
        return [batch]
    by_logger: list[list[T]] = [[] for _ in range(n)]
    where: dict[str, int] = {}
    for name, run in itertools.groupby(batch, key=logger):
        by_logger[where.setdefault(name, len(where) % n)].extend(run)
    if len(where) >= n and max(map(len, by_logger)) * n <= len(batch) * 5 // 4:
        return list(by_logger)
    size = -(-len(batch) // n)
    return [batch[i : i + size] for i in range(0, len(batch), size)]


def _in_order(channels: tuple[int, ...]) -> bool:
    """Strictly rising (so no channel twice); the answers for the tuples met are kept."""
    known = _ORDERED.get(channels)
    if known is None:
        if len(_ORDERED) >= 4096:
            _ORDERED.clear()
        known = _ORDERED[channels] = all(a < b for a, b in itertools.pairwise(channels))
    return known


_ORDERED: dict[tuple[int, ...], bool] = {}


def _cells_of(row: Row) -> list[tuple[Any, ...]]:
    """A grouped row back as its readings' :data:`_fields`."""
    lg, tm, cn, utc = row[0], row[1], row[2], row[3]
    return [
        (lg, tm, cn, ch, ty, va, tx, na, un, utc)
        for ch, ty, va, tx, na, un in zip(*row[4:], strict=True)
    ]


def readings_in(rows: Iterable[Row]) -> int:
    """How many readings ``rows`` hold."""
    return sum(len(r[4]) for r in rows)


SIGNATURE = b"PGCOPY\n\xff\r\n\x00" + bytes(8)
TRAILER = b"\xff\xff"
NULL = b"\xff\xff\xff\xff"
_EPOCH = datetime(2000, 1, 1)
_EPOCH_UTC = datetime(2000, 1, 1, tzinfo=UTC)
_US = timedelta(microseconds=1)
#: Element types (``pg_type.oid``) of the binary arrays here and in :mod:`.pg_arrays`.
INT2, INT4, INT8, FLOAT8, TEXT = 21, 23, 20, 701, 25

_head = struct.Struct("!hi").pack  # the field count, the logger's length
_i4 = struct.Struct("!ii").pack  # length 4, an int4
_i8 = struct.Struct("!iq").pack  # length 8, an int8 (a timestamp's microseconds)
_f8 = struct.Struct("!id").pack  # length 8, a float8
_i2 = struct.Struct("!ih").pack  # length 2, an int2
_array_head = struct.Struct("!iiiIii").pack  # length, ndim 1, has NULLs, element type, n, 1
_F8_NULL = NULL


def clean(text: str) -> bytes:
    """``text`` as PostgreSQL text holds it: UTF-8, its NUL characters dropped (the rule of
    the rows' COPY and of the blocks' parameters, :mod:`.pg_arrays`, alike)."""
    return (text.replace("\x00", "") if "\x00" in text else text).encode()


def _array(oid: int, items: Sequence[bytes | None]) -> bytes:
    """A one-dimensional array field of encoded ``items`` (``None``: NULL)."""
    body = b"".join(NULL if i is None else struct.pack("!i", len(i)) + i for i in items)
    has_null = int(any(i is None for i in items))
    return _array_head(20 + len(body), 1, has_null, oid, len(items), 1) + body


def _texts(items: Sequence[str | None]) -> bytes:
    return _array(TEXT, [None if t is None else clean(t) for t in items])


def _values(items: Sequence[float | None]) -> bytes:
    n = len(items)
    if None not in items:  # one pack: each value after its length (8)
        pack = _F8S.get(n)
        if pack is None:
            pack = _F8S.setdefault(n, struct.Struct("!iiiIii" + "4sd" * n).pack)
        args: list[object] = [_LEN8] * (2 * n)
        args[1::2] = items
        return pack(20 + 12 * n, 1, 0, FLOAT8, n, 1, *args)
    body = b"".join([NULL if v is None else _f8(8, v) for v in items])
    return _array_head(20 + len(body), 1, 1, FLOAT8, n, 1) + body


_LEN8 = struct.pack("!i", 8)
#: Packers of a float8 array without NULLs, by length.
_F8S: dict[int, Callable[..., bytes]] = {}


class Encoder:
    """Binary ``COPY`` data of record rows; remembers the arrays it met (bounded)."""

    #: Arrays remembered before the memory is emptied (each a few hundred bytes).
    LIMIT = 4096

    def __init__(self) -> None:
        self._arrays: dict[tuple[int, tuple[object, ...]], bytes] = {}
        #: A row's channels and types, and its texts, names and units, by those arrays.
        self._layouts: dict[tuple[tuple[object, ...], ...], tuple[bytes, bytes]] = {}
        #: Per logger: its row's head (the field count and the logger), the arrays of its
        #: last row's layout and their encoding. A logger's rows mostly have one layout, so
        #: a row's arrays are compared with its logger's last ones (a tuple compares its
        #: elements by identity first) instead of hashed into :attr:`_layouts` (a tuple's
        #: hash is not kept: five tuples of every channel, row after row).
        self._loggers: dict[str, _Last] = {}

    def _layout(self, key: tuple[tuple[object, ...], ...]) -> tuple[bytes, bytes]:
        ch, ty, tx, na, un = key
        cached = self._cached
        if len(self._layouts) >= self.LIMIT:
            self._layouts.clear()
        got = self._layouts[key] = (
            cached(INT4, ch) + cached(INT2, ty),
            cached(TEXT, tx) + cached(TEXT, na) + cached(TEXT, un),
        )
        return got

    def _cached(self, oid: int, items: tuple[object, ...]) -> bytes:
        key = (oid, items)
        got = self._arrays.get(key)
        if got is None:
            if len(self._arrays) >= self.LIMIT:
                self._arrays.clear()
            if oid == TEXT:
                got = _texts(items)  # type: ignore[arg-type]
            elif oid == INT4:
                got = _array(INT4, [struct.pack("!i", int(i)) for i in items])  # type: ignore[call-overload]
            else:
                got = _array(INT2, [struct.pack("!h", int(i)) for i in items])  # type: ignore[call-overload]
            self._arrays[key] = got
        return got

    def encode(self, rows: Iterable[Row]) -> bytes:
        """``rows`` as a whole binary ``COPY`` stream (signature and trailer included)."""
        return SIGNATURE + self.body(rows) + TRAILER

    def body(self, rows: Iterable[Row]) -> bytes:
        """``rows`` in the binary ``COPY`` format, without the stream's signature and trailer
        (a long stream written in pieces: :data:`SIGNATURE`, bodies, :data:`TRAILER`).

        The values of all the rows are encoded at once when none is NULL
        (:func:`_all_values`), each row's then a slice of them; a time met before in the
        rows is encoded once."""
        rows = rows if isinstance(rows, list) else list(rows)
        out: list[bytes] = []
        add = out.append
        loggers = self._loggers
        times: dict[datetime, bytes] = {}
        values = _all_values(rows)
        at = 0
        for logger, time, counter, utc, ch, ty, va, tx, na, un in rows:
            key = (ch, ty, tx, na, un)
            last = loggers.get(logger)
            if last is None or last[1] != key:
                last = self._last(logger, key)
            add(last[0])
            stamp = times.get(time)
            if stamp is None:
                stamp = times[time] = _i8(8, (time - _EPOCH) // _US)
            add(stamp)
            add(_i4(4, counter))
            add(NULL if utc is None else _i8(8, (utc - _EPOCH_UTC) // _US))
            add(last[2])
            if values is None:
                add(_values(va))
            else:
                n = len(va)
                add(_F8_HEADS.get(n) or _f8_head(n))
                add(values[at : at + 12 * n])
                at += 12 * n
            add(last[3])
        return b"".join(out)

    def _last(self, logger: str, key: tuple[tuple[object, ...], ...]) -> _Last:
        """``logger``'s row head and the encoded arrays of the layout ``key``, kept as its
        last (:attr:`_loggers`)."""
        loggers = self._loggers
        last = loggers.get(logger)
        if last is None:
            if len(loggers) >= self.LIMIT:
                loggers.clear()
            name = clean(logger)
            head = _head(10, len(name)) + name
        else:
            head = last[0]
        arrays = self._layouts.get(key) or self._layout(key)
        got = loggers[logger] = (head, key, arrays[0], arrays[1])
        return got


def _all_values(rows: Sequence[Row]) -> bytes | None:
    """The values of ``rows`` as binary array elements (each its length, 8, then the
    big-endian float8), one after the other; None when one is NULL (or not a float).

    Made in C loops: an ``array`` of doubles, byte-swapped on a little-endian machine, its
    bytes spread over every twelve by extended slices."""
    values = itertools.chain.from_iterable([r[6] for r in rows])
    try:
        doubles = array.array("d", cast(Iterator[float], values))  # a None raises
    except TypeError:
        return None
    if _SWAP:
        doubles.byteswap()
    raw = doubles.tobytes()
    n = len(doubles)
    out = bytearray(12 * n)
    out[3::12] = b"\x08" * n
    for i in range(8):
        out[4 + i :: 12] = raw[i::8]
    return bytes(out)


def _f8_head(n: int) -> bytes:
    """The head of a float8 array of ``n`` elements without NULLs (kept by ``n``)."""
    if len(_F8_HEADS) >= 4096:
        _F8_HEADS.clear()
    got = _F8_HEADS[n] = _array_head(20 + 12 * n, 1, 0, FLOAT8, n, 1)
    return got


_SWAP = sys.byteorder == "little"
#: A logger's row head, its last layout (the arrays channel, type, text, name, unit) and their
#: encoding (channel and type; text, name and unit), :attr:`Encoder._loggers`.
_Last = tuple[bytes, tuple[tuple[object, ...], ...], bytes, bytes]
_F8_HEADS: dict[int, bytes] = {}

"""A batch of readings as PostgreSQL record rows (:mod:`sondalog.collect.pg_rows`), without a
server: the grouping; the encoding is checked against the server by the sink's tests."""

from __future__ import annotations

import dataclasses
import itertools
import random
from datetime import UTC, datetime, timedelta
from unittest import mock

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from readings_gen import rows, text_row

from sondalog.collect import pg_rows
from sondalog.collect.model import Reading


def readings_of(grouped: list[pg_rows.Row]) -> list[Reading]:
    return [
        Reading(lg, ch, t, cn, ty, va, tx, na, un, utc)
        for lg, t, cn, utc, *arrays in grouped
        for ch, ty, va, tx, na, un in zip(*arrays, strict=True)
    ]


def test_a_run_of_a_rows_readings_is_one_row() -> None:
    batch = [*rows("A", 0, 3, channels=4), text_row("A", 1, "x"), *rows("B", 0, 2)]
    got = pg_rows.group(batch)
    assert [(r[0], r[1].minute, r[2], r[4]) for r in got] == [
        ("A", 0, 0, (1, 2, 3, 4)),
        ("A", 1, 0, (1, 2, 3, 4)),
        ("A", 2, 0, (1, 2, 3, 4)),
        ("A", 1, 1, (0,)),
        ("B", 0, 0, (1, 2, 3)),
        ("B", 1, 0, (1, 2, 3)),
    ]
    assert readings_of(got) == batch
    assert pg_rows.readings_in(got) == len(batch)


def test_out_of_order_twice_and_apart_are_merged() -> None:
    one = rows("A", 0, 1, channels=3)
    twice = Reading("A", 2, one[0].time, 0, 1, -1.0)  # channel 2 again: the first kept
    later = rows("A", 0, 1, channels=5)[3:]  # channels 4, 5 after another row
    other = rows("B", 0, 1)
    batch = [one[2], one[0], one[1], twice, *other, *later]
    got = pg_rows.group(batch)
    assert len(got) == 2
    assert got[0][4] == (1, 2, 3, 4, 5)
    assert readings_of(got)[:5] == [*one, *later]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32), st.integers(1, 60))
def test_grouping_keeps_each_reading_once_the_first(seed: int, n: int) -> None:
    rng = random.Random(seed)
    t0 = datetime(2026, 1, 1)
    batch = [
        Reading(rng.choice("AB"), rng.randrange(4), t0 + timedelta(minutes=rng.randrange(3)),
                rng.randrange(2), 1, float(i))
        for i in range(n)
    ]  # fmt: skip
    first: dict[tuple[object, ...], Reading] = {}
    for r in batch:
        first.setdefault((r.logger, r.time, r.counter, r.channel), r)
    got = readings_of(pg_rows.group(batch))
    assert sorted(got, key=lambda r: r.key) == sorted(first.values(), key=lambda r: r.key)
    for row in pg_rows.group(batch):
        assert list(row[4]) == sorted(set(row[4]))


def test_encoding_is_a_whole_binary_copy_stream() -> None:
    data = pg_rows.Encoder().encode(pg_rows.group(rows("A", 0, 2)))
    assert data.startswith(pg_rows.SIGNATURE) and data.endswith(pg_rows.TRAILER)
    assert pg_rows.Encoder().encode([]) == pg_rows.SIGNATURE + pg_rows.TRAILER


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32), st.integers(1, 80), st.integers(1, 12))
def test_pieces_are_the_grouping_cut_between_rows(seed: int, n: int, size: int) -> None:
    """A batch a piece at a time: the rows of :func:`pg_rows.group`, in order, each piece
    cut after whole rows; a row whose readings are in two pieces raises ``Apart``."""
    rng = random.Random(seed)
    t0 = datetime(2026, 1, 1)
    batch = [
        Reading(rng.choice("AB"), rng.randrange(4), t0 + timedelta(minutes=rng.randrange(4)),
                0, 1, float(i))
        for i in range(n)
    ]  # fmt: skip
    got: list[pg_rows.Row] = []
    try:
        for piece in pg_rows.pieces(batch, size):
            assert piece
            got += piece
    except pg_rows.Apart:  # only when a row's readings are in two runs of the batch
        runs = [k for k, _ in itertools.groupby(batch, key=lambda r: (r.logger, r.time))]
        assert len(set(runs)) < len(runs)
        return
    assert got == pg_rows.group(batch)


def test_a_row_is_never_cut_between_pieces() -> None:
    batch = rows("A", 0, 5, channels=3)
    pieces = list(pg_rows.pieces(batch, 4))  # 1 reading, then 4: rows finish the pieces
    assert [len(p) for p in pieces] == [1, 2, 2]
    assert [r for p in pieces for r in p] == pg_rows.group(batch)
    apart = [*batch, Reading("A", 9, batch[0].time, 0, 1, 1.0)]  # the first row, later
    with pytest.raises(pg_rows.Apart):
        list(pg_rows.pieces(apart, 4))
    assert len(list(pg_rows.pieces(apart, 100))) == 1  # one piece: merged as before


VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -0.0, 1.5]), st.none()
)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["A", "B\x00", "Cé"]),
            st.integers(0, 3),  # minute
            st.integers(0, 1),  # counter
            st.lists(st.integers(0, 5), min_size=1, max_size=6),  # channels
            st.lists(VALUES, min_size=6, max_size=6),
            st.booleans(),  # a UTC time
        ),
        max_size=12,
    ),
    st.integers(1, 5),
)
def test_values_encoded_at_once_are_those_of_each_row(
    items: list[tuple[str, int, int, list[int], list[float | None], bool]], cut: int
) -> None:
    """The body's fast path (every value of the rows at once, :func:`pg_rows._all_values`)
    writes the bytes of the row-by-row path (``_values``), on random rows: NULLs, NaN,
    infinities, -0.0, rows of any length, times met again, pieces of any size."""
    t0 = datetime(2026, 1, 1)
    batch = [
        Reading(lg, ch, t0 + timedelta(minutes=m), cn, 1 + ch % 2, values[i], None, f"n{ch}",
                "V", (t0 + timedelta(minutes=m)).replace(tzinfo=UTC) if utc else None)
        for lg, m, cn, channels, values, utc in items
        for i, ch in enumerate(channels)
    ]  # fmt: skip
    rows = pg_rows.group(batch)
    encoder = pg_rows.Encoder()
    fast = [encoder.body(rows[i : i + cut]) for i in range(0, len(rows), cut)]
    assert any(v is None for r in rows for v in r[6]) or not rows or pg_rows._all_values(rows)
    with mock.patch.object(pg_rows, "_all_values", lambda rows: None):
        slow = [pg_rows.Encoder().body(rows[i : i + cut]) for i in range(0, len(rows), cut)]
    assert fast == slow


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["A", "B", "A\x00"]),  # "A\x00" is stored as "A": its own head
            st.lists(st.integers(0, 3), min_size=1, max_size=4, unique=True),  # channels
            st.integers(0, 3),  # which layout of the channels: types, texts, names, units
        ),
        max_size=30,
    ),
    st.integers(1, 6),
    st.integers(1, 40),
)
def test_a_loggers_last_layout_remembered_encodes_as_a_fresh_encoder(
    items: list[tuple[str, list[int], int]], cut: int, limit: int
) -> None:
    """The body's memory of each logger's last layout (its arrays compared, not hashed)
    writes the bytes a fresh encoder writes for each row alone, on random rows whose
    layouts change from row to row of a logger (types, texts, names, units, channels),
    loggers interleaved, and memories emptied when full (``LIMIT``)."""
    t0 = datetime(2026, 1, 1)
    batch = [
        Reading(lg, ch, t0 + timedelta(minutes=i), 0, 1 + (ch + k) % 2,
                None if k == 3 else 1.5, "t" if k == 2 else None, f"n{ch}" if k != 1 else "m",
                "V" if k else None)
        for i, (lg, channels, k) in enumerate(items)
        for ch in sorted(channels)
    ]  # fmt: skip
    rows = pg_rows.group(batch)
    encoder = pg_rows.Encoder()
    with mock.patch.object(pg_rows.Encoder, "LIMIT", limit):
        remembered = b"".join(encoder.body(rows[i : i + cut]) for i in range(0, len(rows), cut))
    alone = b"".join(pg_rows.Encoder().body([row]) for row in rows)
    assert remembered == alone


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["A", "B"]),
            st.sampled_from([(1, 2, 3), (3, 1, 2), (2, 2), (1, 2, 3), (1,), (0, 4)]),
        ),
        max_size=20,
    )
)
def test_rows_of_the_same_channels_out_of_order_each_merged(
    items: list[tuple[str, tuple[int, ...]]],
) -> None:
    """Row after row of the same channels, in order or not (or one twice): every row comes
    out in channel order with its first reading of each channel (the channels known in
    order are remembered from row to row; those out of order must not be)."""
    t0 = datetime(2026, 1, 1)
    batch = [
        Reading(lg, ch, t0 + timedelta(minutes=i), 0, 1, float(10 * i + k))
        for i, (lg, channels) in enumerate(items)
        for k, ch in enumerate(channels)
    ]
    for row in pg_rows.group(batch):
        assert list(row[4]) == sorted(set(row[4]))
    first: dict[tuple[object, ...], Reading] = {}
    for r in batch:
        first.setdefault((r.logger, r.time, r.counter, r.channel), r)
    assert readings_of(pg_rows.group(batch)) == sorted(
        first.values(), key=lambda r: (r.time, r.channel)
    )


def _batch_of_rows(data: st.DataObject, uniform: bool) -> list[Reading]:
    """Random record rows as a logger's are read: each a run of rising channels (all of one
    set when ``uniform``), random loggers, times, counters, values (NaN, None), texts; rows
    sometimes again later (a row in two runs), or out of channel order."""
    t0 = datetime(2026, 1, 1)
    same = data.draw(st.lists(st.integers(-1, 9), min_size=1, max_size=5, unique=True))
    out: list[Reading] = []
    for _ in range(data.draw(st.integers(0, 12))):
        lg = data.draw(st.sampled_from(["A", "B", "Cé", "D\x00"]))
        tm = t0 + timedelta(minutes=data.draw(st.integers(0, 3)))
        cn = data.draw(st.integers(0, 1))
        utc = data.draw(st.sampled_from([None, tm.replace(tzinfo=UTC)]))
        if uniform:
            chs = sorted(same)
        else:
            chs = data.draw(st.lists(st.integers(-1, 9), min_size=1, max_size=5, unique=True))
            chs = sorted(chs) if data.draw(st.integers(0, 9)) else chs
        for ch in chs:
            v = data.draw(VALUES)
            tx = data.draw(st.sampled_from([None, "x", "y\x00"]))
            na = data.draw(st.sampled_from([None, f"T{ch}", "n"]))
            out.append(Reading(lg, ch, tm, cn, data.draw(st.integers(0, 3)), v, tx, na, "V", utc))
    if data.draw(st.booleans()):  # equal keys, other objects (a batch read from the buffer)
        out = [
            Reading(r.logger + "", r.channel, r.time + timedelta(0), r.counter, r.type, r.value,
                    r.text, r.name, r.unit, r.utc)
            for r in out
        ]  # fmt: skip
    return out


@settings(max_examples=300, deadline=None)
@given(st.data(), st.booleans())
def test_grouping_by_column_is_grouping_by_run(data: st.DataObject, uniform: bool) -> None:
    """The fast grouping of a batch (:func:`pg_rows.by_column`) gives the rows of the
    general one, and their bytes, or declines (None) only when a row's readings are not one
    run in rising channel order."""
    batch = _batch_of_rows(data, uniform)
    fast, slow = pg_rows.by_column(batch), pg_rows.by_run(batch)
    runs = [(k, [r.channel for r in g]) for k, g in itertools.groupby(batch, key=pg_rows._key)]
    simple = len({k for k, _ in runs}) == len(runs) and all(c == sorted(set(c)) for _, c in runs)
    assert (fast is not None) == simple
    if fast is not None:
        assert fast == slow
        assert list(map(_ids, fast)) == list(map(_ids, slow))  # the same objects
        assert pg_rows.Encoder().encode(fast) == pg_rows.Encoder().encode(slow)
    assert pg_rows.group(batch) == slow


def _ids(row: pg_rows.Row) -> list[object]:
    return [*map(id, row[:4]), *(tuple(map(id, a)) for a in row[4:])]


def test_rows_as_read_are_grouped_by_column() -> None:
    """Rows of one set of channels, and rows of several (a text row among them), take the
    fast way; equal keys of other objects are one row."""
    uniform = [*rows("A", 0, 3, channels=4), *rows("B", 0, 2, channels=4)]
    mixed = [*rows("A", 0, 3, channels=4), text_row("A", 1, "x"), *rows("B", 0, 2)]
    for batch in (uniform, mixed):
        assert pg_rows.by_column(batch) == pg_rows.by_run(batch) == pg_rows.group(batch)
    copies = [dataclasses.replace(r, time=r.time + timedelta(0)) for r in uniform]
    assert pg_rows.by_column(copies) == pg_rows.by_run(uniform)
    assert pg_rows.by_column([*uniform, uniform[0]]) is None  # a row in two runs

"""The dashboard's extremes of a batch (blocks_rule.aggregate, issue 24): the inlined fast
comparison picks exactly what the block rule (:func:`blocks_rule.take`) picks, on random
batches with ties, NULLs, NaN and infinities."""

from __future__ import annotations

import math
from datetime import datetime, timedelta
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.collect import blocks_rule, pg_rows
from sondalog.collect.model import Reading

T0 = datetime(2026, 1, 1)
VALUES = st.one_of(
    st.none(),
    st.sampled_from([0.0, 1.0, -1.0, 2.5, math.inf, -math.inf, math.nan]),
    st.floats(-10, 10, allow_nan=False),
)


def reference(batch: list[Reading]) -> dict[tuple[Any, ...], list[Any]]:
    """The rule applied reading by reading, for the finest size."""
    size = blocks_rule.SIZES[0]
    out: dict[tuple[Any, ...], list[Any]] = {}
    for r in batch:
        if r.channel <= 0:
            continue
        sec = int((r.time - datetime(1970, 1, 1)).total_seconds())
        key = (r.logger, size, sec - sec % size, r.channel)
        c = out.get(key)
        if c is None:
            out[key] = [r.value, sec, r.value, sec]
        else:
            blocks_rule.take(c, r.value, sec, 0, -1)
            blocks_rule.take(c, r.value, sec, 2, 1)
    return out


def same(a: object, b: object) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)


def reference_sizes(batch: list[Reading]) -> dict[tuple[Any, ...], list[Any]]:
    """The blocks of every size: the finest by the rule (:func:`reference`), each coarser
    block taking the finest ones by :func:`blocks_rule.take` in their order (NaN orders
    nowhere, so the order counts)."""
    fine = reference(batch)
    out = dict(fine)
    for size in blocks_rule.SIZES[1:]:
        for (lg, _, start, ch), c in fine.items():
            key = (lg, size, start - start % size, ch)
            b = out.get(key)
            if b is None:
                out[key] = list(c)
            else:
                blocks_rule.take(b, c[0], c[1], 0, -1)
                blocks_rule.take(b, c[2], c[3], 2, 1)
    return out


@settings(max_examples=400, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["a", "b"]),
            st.integers(0, 3),
            st.one_of(st.integers(0, 4000), st.integers(0, 200_000)),  # blocks of every size
            VALUES,
        ),
        max_size=60,
    )
)
def test_aggregate_matches_the_rule(items: list[tuple[str, int, int, float | None]]) -> None:
    """Every size, NULLs, NaN, infinities and ties included (the coarse blocks' comparison
    is inlined where no value is NULL)."""
    batch = [Reading(lg, ch, T0 + timedelta(seconds=s), 0, 0, v) for lg, ch, s, v in items]
    got = {row[:4]: list(row[4:]) for row in blocks_rule.aggregate(batch)}
    want = reference_sizes(batch)
    assert got.keys() == want.keys()
    for key, c in want.items():
        assert all(same(x, y) for x, y in zip(got[key], c, strict=True)), (key, got[key], c)


def blocks_of(out: list[tuple[Any, ...]]) -> dict[tuple[Any, ...], list[Any]]:
    got = {row[:4]: list(row[4:]) for row in out}
    assert len(got) == len(out)  # each block once
    return got


def assert_same_blocks(a: list[tuple[Any, ...]], b: list[tuple[Any, ...]]) -> None:
    x, y = blocks_of(a), blocks_of(b)
    assert x.keys() == y.keys()
    for key, c in x.items():
        assert all(same(p, q) for p, q in zip(c, y[key], strict=True)), (key, c, y[key])


def record_rows(values: Any) -> Any:
    """Record rows as a logger's download brings them (a row's readings together, by
    channel), their values drawn from ``values``."""
    return st.lists(
        st.tuples(
            st.sampled_from(["a", "b"]),
            st.integers(0, 9000),  # seconds: several blocks of every size
            st.sampled_from([(1, 2, 3), (1, 2, 3), (0,), (2, 5)]),
            st.lists(values, min_size=3, max_size=3),
        ),
        max_size=40,
        unique_by=lambda r: (r[0], r[1]),
    )


ROWS = record_rows(VALUES)
#: Rows without NULL or NaN (so the batch's columns are taken by min/max at once), ties
#: and infinities among them.
CLEAN_ROWS = record_rows(
    st.one_of(st.sampled_from([1.0, -0.0, 0.0, math.inf, -math.inf]), st.floats(-9, 9))
)


def readings_of_rows(items: list[tuple[str, int, tuple[int, ...], list[Any]]]) -> list[Reading]:
    return [
        Reading(lg, ch, T0 + timedelta(seconds=s), 0, 0, v)
        for lg, s, channels, values in items
        for ch, v in zip(channels, values, strict=False)
    ]


@settings(max_examples=400, deadline=None)
@given(st.one_of(ROWS, CLEAN_ROWS))
def test_aggregate_of_rows_is_aggregate_of_their_readings(
    items: list[tuple[str, int, tuple[int, ...], list[float | None]]],
) -> None:
    """By column (min/max of a block's rows of one channel) exactly as reading by reading,
    NULLs, NaN, infinities, ties and rows out of time order included, and batches without
    NULL or NaN (each block's columns by min/max, none tested)."""
    batch = readings_of_rows(items)
    assert_same_blocks(
        blocks_rule.aggregate_rows(pg_rows.group(batch)), blocks_rule.aggregate(batch)
    )


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["a", "b"]),
            st.integers(0, 3),
            st.integers(0, 9000),
            st.one_of(st.none(), st.floats(-10, 10, allow_nan=False)),
        ),
        max_size=60,
        unique_by=lambda r: (r[0], r[1], r[2]),
    )
)
def test_aggregate_of_rows_of_any_batch(items: list[tuple[str, int, int, float | None]]) -> None:
    """Readings in any order (rows merged by :func:`pg_rows.group`), without NaN: the same."""
    batch = [Reading(lg, ch, T0 + timedelta(seconds=s), 0, 0, v) for lg, ch, s, v in items]
    assert_same_blocks(
        blocks_rule.aggregate_rows(pg_rows.group(batch)), blocks_rule.aggregate(batch)
    )


# -- the blocks a sink knows stored (blocks_rule.Written) ---------------------------------


def stored_after(stored: dict[tuple[Any, ...], list[Any]], block: tuple[Any, ...]) -> None:
    """The server's rule (blocks_rule.MERGE) without NaN: take the block's extremes."""
    c = stored.get(block[:4])
    if c is None:
        stored[block[:4]] = list(block[4:])
    else:
        blocks_rule.take(c, block[4], block[5], 0, -1)
        blocks_rule.take(c, block[6], block[7], 2, 1)


BLOCK = st.tuples(
    st.just("a"),
    st.just(1800),
    st.sampled_from([0, 1800]),
    st.integers(1, 2),
    st.one_of(st.none(), st.sampled_from([1.0, 2.0, 3.0])),
    st.integers(0, 3),
    st.one_of(st.none(), st.sampled_from([1.0, 2.0, 3.0])),
    st.integers(0, 3),
).map(lambda b: b if (b[4] is None) == (b[6] is None) else (*b[:6], b[4], b[7]))


@settings(max_examples=400, deadline=None)
@given(st.lists(st.tuples(st.lists(BLOCK, max_size=5), st.booleans()), max_size=12))
def test_a_block_left_out_changes_nothing(batches: list[tuple[list[Any], bool]]) -> None:
    """Batch after batch, some committed and some rolled back (not noted): a block that
    ``changing`` leaves out would not change the stored one, and every block it keeps is
    one the server would have to look at."""
    written = blocks_rule.Written()
    stored: dict[tuple[Any, ...], list[Any]] = {}
    for blocks, committed in batches:
        sent = written.changing(blocks)
        assert all(b in sent for b in blocks if b[:4] not in stored)
        for b in blocks:
            if b not in sent:
                before = dict((k, list(v)) for k, v in stored.items())
                stored_after(stored, b)
                assert stored == before, b
        if committed:
            for b in sent:
                stored_after(stored, b)
            written.note(sent)


def test_nan_is_always_sent_and_the_memory_is_bounded() -> None:
    written = blocks_rule.Written()
    block = ("a", 1800, 0, 1, 1.0, 5, 2.0, 6)
    written.note([block])
    assert written.changing([block]) == []
    assert written.changing([("a", 1800, 0, 1, 1.0, 4, 2.0, 6)]) != []  # a tie, earlier
    nan = ("a", 1800, 0, 1, math.nan, 7, math.nan, 7)
    assert written.changing([nan]) == [nan]
    written.note([nan])
    written.note([("a", 1800, 1800, 1, math.nan, 7, math.nan, 7)])
    assert len(written) == 1  # NaN is not remembered
    written.LIMIT = 3
    written.note([("b", 1800, s, 1, 1.0, s, 1.0, s) for s in range(5)])
    assert len(written) == 3 and written.changing([block]) == [block]  # the oldest forgotten
    written.clear()
    assert len(written) == 0


def noted_one_at_a_time(
    known: dict[tuple[Any, ...], tuple[Any, ...]], blocks: list[tuple[Any, ...]], limit: int
) -> None:
    """``Written.note`` as it was: each block taken, the oldest forgotten one at a time."""
    for b in blocks:
        old = known.pop(b[:4], None)
        c = list(b[4:]) if old is None else list(old)
        if old is not None:
            blocks_rule.take(c, b[4], b[5], 0, -1)
            blocks_rule.take(c, b[6], b[7], 2, 1)
        if c[0] == c[0] and c[2] == c[2]:
            known[b[:4]] = tuple(c)
            if len(known) > limit:
                del known[next(iter(known))]


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.lists(BLOCK.map(lambda b: (b[0], b[1], b[2] * (1 + b[5]), *b[3:])), max_size=8,
                 unique_by=lambda b: b[:4]),
        max_size=12,
    ),
    st.integers(1, 6),
)  # fmt: skip
def test_the_oldest_blocks_are_forgotten_first(
    batches: list[list[tuple[Any, ...]]], limit: int
) -> None:
    """Forgetting at the end of a batch keeps exactly the blocks (and what is known of them,
    in their order) that forgetting one at a time kept."""
    written = blocks_rule.Written()
    written.LIMIT = limit
    known: dict[tuple[Any, ...], tuple[Any, ...]] = {}
    for blocks in batches:
        written.note(blocks)
        noted_one_at_a_time(known, blocks, limit)
        assert list(written._known.items()) == list(known.items())
        assert len(written) <= limit


@settings(max_examples=400, deadline=None)
@given(
    st.one_of(ROWS, CLEAN_ROWS),
    st.lists(st.integers(1, 8), max_size=6),
    st.sampled_from([1, 2, 5, blocks_rule.Aggregate.AT_ONCE]),
)
def test_blocks_of_pieces_are_those_of_the_rows_together(
    items: list[tuple[str, int, tuple[int, ...], list[float | None]]],
    cuts: list[int],
    at_once: int,
) -> None:
    """``Aggregate`` given the rows a piece at a time (as the sink sends them) and taking
    them ``at_once`` rows at a time, a block's rows in several takes, out of time order,
    NULLs, NaN and ties included: exactly the blocks of the readings taken one by one."""
    batch = readings_of_rows(items)
    rows = pg_rows.group(batch)
    pieces = blocks_rule.Aggregate()
    pieces.AT_ONCE = at_once
    start = 0
    for n in [*cuts, len(rows)]:
        pieces.add(rows[start : start + n])
        start += n
    assert_same_blocks(pieces.blocks(), blocks_rule.aggregate(batch))

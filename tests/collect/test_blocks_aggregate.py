"""The dashboard's extremes of a batch (blocks_rule.aggregate, issue 24): the inlined fast
comparison picks exactly what the block rule (:func:`blocks_rule.take`) picks, on random
batches with ties, NULLs, NaN and infinities."""

from __future__ import annotations

import math
from datetime import datetime, timedelta
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.collect import blocks_rule
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


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["a", "b"]),
            st.integers(0, 3),
            st.integers(0, 4000),
            VALUES,
        ),
        max_size=60,
    )
)
def test_aggregate_matches_the_rule(items: list[tuple[str, int, int, float | None]]) -> None:
    batch = [Reading(lg, ch, T0 + timedelta(seconds=s), 0, 0, v) for lg, ch, s, v in items]
    got = {row[:4]: list(row[4:]) for row in blocks_rule.aggregate(batch)}
    want = reference(batch)
    finest = {k: v for k, v in got.items() if k[1] == blocks_rule.SIZES[0]}
    assert finest.keys() == want.keys()
    for key, c in want.items():
        assert all(same(x, y) for x, y in zip(finest[key], c, strict=True)), key

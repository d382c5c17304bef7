"""A channel's blocks as :func:`sondalog.web.blocks.by_channel` reads them (issue 24, seventh
round): on PostgreSQL the arrays of a channel's blocks in any order (the server's) put in
time order, each block with its bucket: of its place when the channel has every block of
the plan, else of its tmin; the same as the bucket of its start (what the statement
computed before), on random plans and blocks."""

from __future__ import annotations

import random

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.web import blocks
from sondalog.web.times import from_epoch


@settings(max_examples=400, deadline=None)
@given(
    seed=st.integers(0, 2**32),
    start=st.integers(1_600_000_000, 1_900_000_000),
    length=st.integers(1, 86_400 * 400),
    buckets=st.sampled_from([1, 2, 3, 5, 30, 100, 999, 1000]),
    every=st.booleans(),
)
def test_blocks_in_time_order_with_the_bucket_of_their_start(
    seed: int, start: int, length: int, buckets: int, every: bool
) -> None:
    p = blocks.plan(from_epoch(start), from_epoch(start + length), buckets)
    if not p.size:
        return
    rng = random.Random(seed)
    kept = list(range(p.n)) if every else sorted(rng.sample(range(p.n), rng.randrange(p.n + 1)))
    want = []
    for j in kept:
        lo = p.a + j * p.size  # the block's start: its bucket as the statement had it
        tmin, tmax = lo + rng.randrange(p.size), lo + rng.randrange(p.size)
        vmin = rng.choice([None, -1.5, 0.0, 2.0])
        vmax = rng.choice([None, 3.25, vmin])
        want.append((7, (lo - p.a) // p.size * p.m // p.n, vmin, tmin, vmax, tmax))
    got = want[:]
    if rng.random() < 0.5:
        rng.shuffle(got)
    elif rng.random() < 0.5:
        got.reverse()
    columns = [[b[i] for b in got] for i in range(2, 6)]
    whole: list[int] = []
    assert list(blocks._blocks(7, columns, p, whole)) == want
    assert whole in ([], [j * p.m // p.n for j in range(p.n)])
    assert list(blocks._blocks(7, columns, p, whole)) == want  # with ``whole`` kept

"""Signals read as columns (issue 24, ``signals.signal_column``) give the very floats of the
signal read time by time, for every model, shifted to a simulation's start or not, and a
random walk's steps are ``random.Random(seed).gauss`` whatever the batches it is made in."""

from __future__ import annotations

import math
import random

from hypothesis import given
from hypothesis import strategies as st

from sondalog.backends.sim.signals import (
    Clamp,
    RandomWalk,
    Schedule,
    Signal,
    constant,
    ramp,
    shifted,
    signal_column,
    sine,
)

T0 = 1_000_000_000.0


def models(seed: int) -> list[Signal]:
    return [
        constant(4.5),
        sine(12.4, 0.3, 7200.0, -21600.0, T0),
        ramp(300.0, -0.01, T0, Clamp(290.0, 299.0)),
        ramp(1.0, 0.5, T0, lambda v: v),
        RandomWalk(1.1, 0.05, 60.0, seed, T0, Clamp(0.2, 2.0)),
        RandomWalk(1.1, 0.05, 45.0, seed, T0, lambda v: v),
        Schedule([(0.0, 0.3), (900.0, 1.9), (2000.0, 0.0)], T0, True, True),
    ]


@given(
    seed=st.integers(0, 1000),
    offsets=st.lists(st.floats(-3000.0, 10**6, allow_nan=False), max_size=60),
    start=st.sampled_from([None, 0.0, T0 - 12345.5]),
)
def test_a_column_is_the_signal_time_by_time(
    seed: int, offsets: list[float], start: float | None
) -> None:
    times = [T0 + x for x in offsets]
    for by_time, by_column in zip(models(seed), models(seed), strict=True):
        if start is not None:
            by_time, by_column = shifted(by_time, start), shifted(by_column, start)
        expected = [by_time(t) for t in times]
        assert signal_column(by_column, times) == expected
        assert signal_column(shifted(by_column, 7.0), times) == [
            shifted(by_time, 7.0)(t) for t in times
        ]


@given(seed=st.integers(0, 2**32), reads=st.lists(st.integers(0, 6000), min_size=1, max_size=8))
def test_a_random_walk_steps_by_random_gauss(seed: int, reads: list[int]) -> None:
    walk = RandomWalk(1.0, 0.05, 60.0, seed, 0.0, Clamp(0.2, 2.0))
    got = [walk(60.0 * index) for index in reads]  # (batches end wherever the reads fall)
    rng = random.Random(seed)
    steps = [1.0]
    for _ in range(max(reads)):
        steps.append(min(max(steps[-1] + rng.gauss(0.0, 0.05), 0.2), 2.0))
    assert got == [steps[index] for index in reads]
    assert not any(math.isnan(v) for v in got)

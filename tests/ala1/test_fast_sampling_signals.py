"""Signals read as columns (issue 24, ``signals.signal_column``) give the very floats of the
signal read time by time, for every model, shifted to a simulation's start or not, and a
random walk's steps are ``random.Random(seed).gauss`` whatever the batches it is made in."""

from __future__ import annotations

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.backends.sim.logger import PulseSource
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
        sine(12.4, 0.3, 86400.0, 0.0, 0.0),  # (a site file's: origin and phase +0.0)
        sine(0.0, 1.0, 7200.0, -0.0, -0.0),  # (-0.0 is subtracted: t - -0.0 is not t at -0.0)
        ramp(300.0, -0.01, T0, Clamp(290.0, 299.0)),
        ramp(1.0, 0.5, T0, lambda v: v),
        RandomWalk(1.1, 0.05, 60.0, seed, T0, Clamp(0.2, 2.0)),
        RandomWalk(1.1, 0.05, 45.0, seed, T0, lambda v: v),
        Schedule([(0.0, 0.3), (900.0, 1.9), (2000.0, 0.0)], T0, True, True),
    ]


@given(
    seed=st.integers(0, 1000),
    offsets=st.lists(st.floats(-3000.0, 10**6, allow_nan=False), max_size=60),
    start=st.sampled_from([None, 0.0, T0 - 12345.5, T0]),
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


@given(
    burst_rate=st.sampled_from([0.0005, 0.01, 0.3]),
    seed=st.integers(0, 50),
    gaps=st.lists(st.integers(0, 200), min_size=1, max_size=60),
    window=st.sampled_from([None, 1, 60]),
    at_ends=st.lists(st.integers(0, 59), max_size=4),
    back=st.integers(0, 80),
)
@settings(max_examples=400)  # (an end that goes back, among pulses: rare enough to need more)
def test_pulse_counts_are_the_counts_window_by_window(
    burst_rate: float, seed: int, gaps: list[int], window: int | None, at_ends: list[int], back: int
) -> None:
    """:meth:`PulseSource.counts` of many windows (issue 24: ends that ascend, events placed
    once each; ends that do not, a search each) as :meth:`PulseSource.count` of each; some
    pulses right at the end of a window."""
    ends = [1000.0 + sum(gaps[: k + 1]) for k in range(len(gaps))]
    if back < len(ends):  # (an end before the one before it)
        ends[back] -= 300.0
    starts = [end - (window or 60) for end in ends] if window else [1000.0, *ends[:-1]]
    events = sorted({ends[k % len(ends)] for k in at_ends})
    sources = [
        PulseSource(True, 0, burst_rate=burst_rate, burst=3, seed=seed, _events=list(events))
        for _ in range(2)
    ]
    expected = [sources[0].count(a, b) for a, b in zip(starts, ends, strict=True)]
    assert sources[1].counts(starts, ends) == expected


@given(
    seed=st.integers(0, 1000),
    first=st.one_of(st.integers(-200_000, 10**6).map(float), st.floats(-3000.0, 10**6)),
    step=st.sampled_from([1.0, 10.0, 30.0, 45.0, 60.0, 120.0, 300.0, 600.0, 60.5]),
    count=st.integers(0, 80),
    start=st.sampled_from([None, 0.0, T0 - 12345.0, T0 - 12345.5]),
)
def test_a_column_of_regular_instants_is_the_signal_time_by_time(
    seed: int, first: float, step: float, count: int, start: float | None
) -> None:
    """Sampling instants a period apart (a stretch of the series path): a random walk takes
    its steps one after the other when the period is whole intervals (issue 24)."""
    times = [T0 + first + k * step for k in range(count)]
    for by_time, by_column in zip(models(seed), models(seed), strict=True):
        if start is not None:
            by_time, by_column = shifted(by_time, start), shifted(by_column, start)
        assert signal_column(by_column, times) == [by_time(t) for t in times]
        assert signal_column(by_column, times, 7.0) == [by_time(t - 7.0) for t in times]

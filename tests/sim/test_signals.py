"""Simulated signals (backends/sim/signals.py): a seeded random walk is the running sum of
``random.Random(seed).gauss(0, step)``, clamped, one step per interval, however it is read
(issue 11 makes its steps in batches)."""

from __future__ import annotations

import random

from hypothesis import given
from hypothesis import strategies as st

from sondalog.backends.sim.signals import RandomWalk


def reference(start: float, step: float, seed: int, count: int) -> list[float]:
    rng = random.Random(seed)
    values = [min(2.0, max(0.0, start))]
    for _ in range(count):
        values.append(min(2.0, max(0.0, values[-1] + rng.gauss(0, step))))
    return values


@given(
    seed=st.integers(0, 2**32),
    step=st.floats(0.001, 0.5),
    reads=st.lists(st.floats(-100.0, 5000.0 * 60), min_size=1, max_size=20),
)
def test_a_walk_is_the_seeded_gauss_sequence_in_any_reading_order(
    seed: int, step: float, reads: list[float]
) -> None:
    walk = RandomWalk(1.0, step, 60.0, seed, 0.0, lambda v: min(2.0, max(0.0, v)))
    expected = reference(1.0, step, seed, 5001)
    for t in reads:
        assert walk(t) == expected[max(0, int(t // 60.0))]

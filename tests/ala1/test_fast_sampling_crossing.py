"""A crossing over a series of samples (issue 24) against the sample-by-sample crossing.

:meth:`Crossing.first_of` must trigger at the very sample :meth:`Crossing.sample` first
triggers at, and leave the side as the last sample leaves it (§6.14.7, §6.14.7.4), for any
texts: values, empty texts (no valid value), texts that are no number, zero and negative
hystereses, a side known or not yet.
"""

from __future__ import annotations

from collections.abc import Callable
from decimal import Decimal

from hypothesis import given
from hypothesis import strategies as st

from sondalog.ala1.messages.crossing import Crossing

TEXTS = st.one_of(
    st.integers(-12, 12).map(lambda n: f"{n / 10:.1f}"),
    st.sampled_from(["", "x", " 1.5", "-0.0", "1.50"]),
)


@given(
    st.sampled_from(["UP", "DOWN"]),
    st.integers(-5, 5),
    st.integers(-4, 4).map(lambda n: 2 * n),  # (often a sample right at value +- h/2)
    st.sampled_from([None, True, False]),
    st.lists(TEXTS, max_size=60),
)
def test_first_of_is_sample_by_sample(
    function: str, value: int, hysteresis: int, above: bool | None, texts: list[str]
) -> None:
    one = Crossing(function, Decimal(value) / 10, Decimal(hysteresis) / 10, above)
    many = Crossing(function, Decimal(value) / 10, Decimal(hysteresis) / 10, above)
    expected = next((k for k, text in enumerate(texts) if one.sample(text)), None)
    for text in texts[(expected if expected is not None else len(texts)) + 1 :]:
        one.sample(text)
    assert many.first_of(texts) == expected
    assert many.above == one.above


VALUES = st.one_of(st.none(), st.integers(-1, 1), st.integers(-40, 40).map(lambda n: n / 100))


def _shown(decimals: int) -> Callable[[float | None], str]:
    """A value as a channel with ``decimals`` decimals shows it (no value: the empty text)."""
    return lambda value: "" if value is None else f"{value:.{decimals}f}"


@given(
    st.sampled_from(["UP", "DOWN"]),
    st.integers(-5, 5),
    st.integers(-4, 4).map(lambda n: 2 * n),
    st.sampled_from([None, True, False]),
    st.lists(st.tuples(st.integers(0, 2), st.lists(VALUES, max_size=30)), min_size=2, max_size=4),
)
def test_first_in_values_is_first_of_their_texts(
    function: str,
    value: int,
    hysteresis: int,
    above: bool | None,
    series: list[tuple[int, list[float | None]]],
) -> None:
    """The watched channel's samples as values, series after series, their codes kept
    (the series observer): the same triggers and side as their texts, in whatever format
    each series shows them (hundredths rendered with 0-2 decimals round differently)."""
    texts = Crossing(function, Decimal(value) / 10, Decimal(hysteresis) / 10, above)
    values_ = Crossing(function, Decimal(value) / 10, Decimal(hysteresis) / 10, above)
    for decimals, values in series:
        shown = _shown(decimals)
        expected = texts.first_of([shown(v) for v in values])
        assert values_.first_in(values, shown, decimals) == expected
        assert values_.above == texts.above

"""A crossing over a series of samples (issue 24) against the sample-by-sample crossing.

:meth:`Crossing.first_of` must trigger at the very sample :meth:`Crossing.sample` first
triggers at, and leave the side as the last sample leaves it (§6.14.7, §6.14.7.4), for any
texts: values, empty texts (no valid value), texts that are no number, zero and negative
hystereses, a side known or not yet.
"""

from __future__ import annotations

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

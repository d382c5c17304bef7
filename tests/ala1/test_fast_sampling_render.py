"""Values render by the digits of their repr (issue 24) exactly as through ``Decimal``:
rounding half away from zero (§4.3.5), no ``-0``, any number of decimals."""

from __future__ import annotations

import math
from decimal import Decimal

from hypothesis import example, given
from hypothesis import strategies as st

from sondalog.ala1 import measure
from sondalog.ala1.conditions import _unit_of
from sondalog.ala1.measure import KNOWN_UNITS, ChannelConfig, Input, format_values
from sondalog.ala1.rendering import fixed as _fixed
from sondalog.ala1.rendering import render as _render
from sondalog.ala1.rendering import value_units
from sondalog.ala1.tokens import NumberFormat

values = st.one_of(
    st.floats(min_value=-1e15, max_value=1e15, allow_nan=False, exclude_min=True),
    st.integers(-(10**6), 10**6).map(lambda n: n / 1000),  # halves at the last decimal
    st.integers(-(10**6), 10**6).map(lambda n: n * 0.005),
)


@given(value=values, decimals=st.integers(0, 9))
@example(value=0.05, decimals=1)
@example(value=-0.05, decimals=1)
@example(value=-0.04, decimals=1)
@example(value=-0.0, decimals=2)
@example(value=2.675, decimals=2)  # 2.67499999... as a float; its repr says 2.675
@example(value=9.995, decimals=2)
@example(value=-999.5, decimals=0)
@example(value=1e-05, decimals=3)  # an exponent: the Decimal way
def test_render_by_digits_is_the_decimal_rendering(value: float, decimals: int) -> None:
    expected = NumberFormat(0, decimals).render(Decimal(repr(value)))
    got = _render(repr(value), decimals)
    assert got is None if "e" in repr(value) else got == expected, (value, got, expected)


@given(value=values, decimals=st.integers(0, 9))
@example(value=0.05, decimals=1)
@example(value=-0.05, decimals=1)
@example(value=-0.04, decimals=1)
@example(value=-0.0, decimals=2)
@example(value=0.0, decimals=0)
@example(value=2.675, decimals=2)
@example(value=1.005, decimals=2)  # 1.00499999999999989...: format says 1.00, the repr 1.01
@example(value=0.125, decimals=2)  # exact in binary: format rounds half to even
@example(value=9.995, decimals=2)
@example(value=-999.5, decimals=0)
@example(value=0.5, decimals=0)
@example(value=99999.99999, decimals=9)
@example(value=0.12450000001, decimals=2)  # near a boundary, not on it
@example(value=0.1245, decimals=3)
@example(value=-2.0000499999999, decimals=4)
@example(value=8589934.5915, decimals=3)  # just above 2**33 / 10**3
def test_render_by_format_is_the_decimal_rendering(value: float, decimals: int) -> None:
    """``_fixed`` (issue 24) renders as :func:`_render` and ``Decimal`` do, or declines."""
    expected = NumberFormat(0, decimals).render(Decimal(repr(value)))
    got = _fixed(value, decimals)
    assert got is None or got == expected, (value, got, expected)
    if abs(value) < 10.0 ** (13 - decimals) and abs(value) >= 1e-4 and got is None:
        assert f"{value:.{decimals + 1}f}".endswith("5"), value  # declines only near ties


ODD = [math.nan, -math.inf, 1e16, 0.0, -0.0, 5e-05]  # (no value shown, or the Decimal way)


def _config(width: int, decimals: int) -> ChannelConfig:
    nothing = Input(0, 0, "", 0, 1.0, 0.0, 1.0, 0.0, 0, 0)
    return ChannelConfig(
        1, 3, (nothing, nothing), "", "", 1.0, 0.0, NumberFormat(width, decimals), 60, "", 0,
        Decimal(0), 0,
    )  # fmt: skip


@given(
    values=st.lists(
        st.one_of(values, st.none(), st.sampled_from([math.nan, -math.inf, 1e16])), max_size=30
    ),
    width=st.integers(0, 9),
    decimals=st.integers(0, 9),
)
def test_a_series_formats_as_each_value_through_decimal(
    values: list[float | None], width: int, decimals: int
) -> None:
    """``format_values`` (issue 24: the series path's texts, new values by their rounded
    ``value * 10**decimals``) shows each value as ``NumberFormat.render`` of its repr does;
    no value, a NaN and values beyond the limit as the empty field."""
    fmt = NumberFormat(width, decimals)
    expected = [
        fmt.render(Decimal(repr(v))) if v is not None and math.isfinite(v) and abs(v) < 1e15 else ""
        for v in values
    ]
    assert format_values(_config(width, decimals), values) == expected
    assert format_values(_config(width, decimals), values, fresh=True) == expected  # (averages)


@given(
    units=st.lists(st.integers(-(10**5), 10**5), min_size=1, max_size=10),
    offsets=st.lists(st.floats(-0.49, 0.49), min_size=1, max_size=30),
    width=st.integers(0, 9),
    decimals=st.integers(0, 4),
)
def test_values_of_the_same_units_format_alike(
    units: list[int], offsets: list[float], width: int, decimals: int
) -> None:
    """Averages are new floats of units met before (texts kept by units, issue 24): each
    still shows as ``NumberFormat.render`` of its repr, series after series."""
    fmt = NumberFormat(width, decimals)
    scale = 10.0**decimals
    for shift in (0.0, 0.25):
        values = [
            (units[k % len(units)] + offset + shift) / scale for k, offset in enumerate(offsets)
        ]
        expected = [fmt.render(Decimal(repr(v))) for v in values]
        assert format_values(_config(width, decimals), values) == expected
        assert format_values(_config(width, decimals), values, fresh=True) == expected


@given(
    values=st.lists(st.one_of(values, st.floats(-1e6, 1e6)), max_size=30),
    width=st.integers(0, 9),
    decimals=st.integers(0, 9),
    fresh=st.booleans(),
)
def test_texts_rendered_by_units_are_known_in_units(
    values: list[float], width: int, decimals: int, fresh: bool
) -> None:
    """The texts ``format_values`` renders by their units are handed to the record
    conditions in those units (issue 24, fifth round): each the number of the channel's
    format that ``conditions`` would otherwise match and parse, and the value's units."""
    for kept in (KNOWN_UNITS, measure._BY_UNITS, measure._RENDERED):  # (rendered anew)
        kept.clear()
    texts = format_values(_config(width, decimals), values, fresh=fresh)
    known = KNOWN_UNITS.get(decimals, {})
    for text, units in known.items():
        assert units == _unit_of(text, decimals), (text, units)
        assert text in texts
    for text, value in zip(texts, values, strict=True):
        if text in known:
            assert known[text] == round(Decimal(text.strip()).scaleb(decimals)), (text, value)


@given(
    units=st.lists(st.integers(-(10**7), 10**7), min_size=1, max_size=30),
    offsets=st.lists(
        st.one_of(st.floats(-0.5, 0.5), st.sampled_from([0.4999, -0.4999, 0.49995, 0.5])),
        min_size=1,
        max_size=30,
    ),
    odd=st.lists(
        st.tuples(st.integers(0, 40), st.sampled_from([math.nan, math.inf, -math.inf, 0.0])),
        max_size=3,
    ),
    width=st.integers(0, 9),
    decimals=st.integers(0, 6),
    fresh=st.booleans(),
)
def test_a_series_of_numbers_formats_by_its_rounded_units(
    units: list[int],
    offsets: list[float],
    odd: list[tuple[int, float]],
    width: int,
    decimals: int,
    fresh: bool,
) -> None:
    """A series of numbers only (issue 24, sixth round: the bounds checked once for the
    series, each value's units rounded by adding and subtracting 1.5 * 2**52): values near
    and on halves of the last decimal, a NaN, an infinity or a zero anywhere among them
    (min and max of a series with a NaN depend on where it is) show as through Decimal."""
    fmt = NumberFormat(width, decimals)
    scale = 10.0**decimals
    values = [(units[k % len(units)] + offset) / scale for k, offset in enumerate(offsets)]
    for at, value in odd:
        values.insert(min(at, len(values)), value)
    expected = [
        fmt.render(Decimal(repr(v))) if math.isfinite(v) and abs(v) < 1e15 else "" for v in values
    ]
    assert format_values(_config(width, decimals), values, fresh=fresh) == expected


@given(
    value=st.one_of(values, st.none(), st.sampled_from([math.nan, math.inf, -math.inf])),
    decimals=st.integers(0, 9),
    width=st.sampled_from([0, 6, 12]),
)
@example(value=2.5, decimals=0, width=0)  # a half: half to even (2) is not its text (3)
@example(value=0.125, decimals=2, width=6)
@example(value=-0.004, decimals=2, width=0)  # units -0.0, text 0.00
@example(value=1e-05, decimals=3, width=0)  # a repr with an exponent
@example(value=-5.5e-08, decimals=9, width=0)
@example(value=-0.0, decimals=0, width=6)
@example(value=8589934.5915, decimals=3, width=0)
def test_value_units_are_the_digits_of_the_text(
    value: float | None, decimals: int, width: int
) -> None:
    """``value_units`` (issue 24, seventh round: record conditions decided before any text
    is rendered): where it gives units, ``int`` of the digits of the value's text (the
    Decimal rendering) is those units."""
    (units,) = value_units(decimals, [value])
    if units is not None:
        assert value is not None
        text = NumberFormat(width, decimals).render(Decimal(repr(value)))
        assert int(text.replace(".", "")) == units, (value, text, units)

"""A channel without tables as a column (issue 24, ``columns.channel_column``'s plain
calculation) against :func:`columns.channel_plan`'s value by value: the very floats, signed
zeros included, for unit and other calibrations (counts of pulses are mostly zeros)."""

from __future__ import annotations

import math
from decimal import Decimal

from hypothesis import example, given
from hypothesis import strategies as st

from sondalog.ala1.columns import affine, channel_column, channel_plan
from sondalog.ala1.measure import ChannelConfig, Input, Measurer
from sondalog.ala1.tokens import NumberFormat
from sondalog.backends.sim.logger import default_hardware

factors = st.sampled_from([1.0, 1.0, 0.0, -0.0, -1.0, 2.5, 1e-3])
readings = st.one_of(
    st.sampled_from([0.0, -0.0, 1.0, 12.0, math.inf, -math.inf, math.nan]),
    st.none(),
    st.floats(allow_nan=False),
)


def _config(m1: float, a1: float, mult: float, add: float) -> ChannelConfig:
    first = Input(0, 0, "", 0, 1.0, 0.0, m1, a1, 0, 0)
    return ChannelConfig(
        1, 3, (first, first), "", "", mult, add, NumberFormat(6, 1), 60, "", 0, Decimal(0), 0
    )


def _bits(values: list[float | None]) -> list[str | None]:
    return [None if v is None else float(v).hex() for v in values]


@given(
    m1=factors,
    a1=factors,
    mult=factors,
    add=factors,
    rs=st.lists(readings, max_size=40),
    unit=st.booleans(),
)
def test_a_plain_column_is_the_plan_value_by_value(
    m1: float, a1: float, mult: float, add: float, rs: list[float | None], unit: bool
) -> None:
    if unit:  # (the calibrations that change nothing, but for a -0.0)
        m1, a1, mult, add = 1.0, 0.0, 1.0, 0.0
    measurer = Measurer(default_hardware(0.0))
    cfg = _config(m1, a1, mult, add)
    _, calc = channel_plan(measurer, cfg)
    many = channel_column(measurer, cfg)
    assert many is not None
    assert _bits(many(rs)) == _bits([calc(r) for r in rs])


@given(
    values=st.lists(readings, max_size=40),
    mult=st.sampled_from([1.0, 1.0, -1.0, 2.5]),
    add=st.sampled_from([0.0, 0.0, -0.0, 0.25]),
    fresh=st.booleans(),
)
@example(values=[1.0, -0.0], mult=1.0, add=0.0, fresh=True)
@example(values=[None, 0.0], mult=1.0, add=0.0, fresh=False)
def test_affine_is_each_value_times_mult_plus_add(
    values: list[float | None], mult: float, add: float, fresh: bool
) -> None:
    """``affine`` (issue 24, sixth round: the values themselves once ``all`` finds no zero of
    either sign) gives ``v * mult + add`` of each value bit for bit: a -0.0 becomes 0.0."""
    expected = [None if v is None else v * mult + add for v in values]
    assert _bits(affine(list(values), mult, add, fresh)) == _bits(expected)

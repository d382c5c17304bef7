"""Conversion tables over columns (issue 24, :mod:`sondalog.ala1.curves`) give the very floats
of :class:`Curve` and :class:`Surface` value by value, and raise where one of them raises (a
NaN), on random tables and random columns with repeats, zeros of both signs, None and
infinities."""

from __future__ import annotations

import math
import struct
from collections.abc import Callable

from hypothesis import given
from hypothesis import strategies as st

from sondalog.ala1.curves import curve_column, surface_column
from sondalog.protocol.tables import Curve, Surface

finite = st.floats(-1e6, 1e6, allow_nan=False)
special = st.sampled_from([0.0, -0.0, math.inf, -math.inf, 1e-300, -2.5])
some = st.one_of(finite, special, st.none())
points = st.lists(finite, min_size=1, max_size=6, unique=True).map(sorted)


@st.composite
def curves(draw: st.DrawFn) -> Curve:
    xs = draw(points)
    ys = draw(st.lists(st.one_of(finite, special), min_size=len(xs), max_size=len(xs)))
    return Curve(tuple(xs), tuple(ys))


def _same(a: list[float | None], b: list[float | None]) -> bool:
    """Equal floats bit for bit (the sign of a zero too)."""
    pack = lambda v: None if v is None else struct.pack("d", v)  # noqa: E731
    return [pack(v) for v in a] == [pack(v) for v in b]


def _one_by_one(fn: object, *columns: list[float | None]) -> list[float | None] | None:
    out: list[float | None] = []
    for items in zip(*columns, strict=True):
        if any(v is None for v in items):
            out.append(None)
            continue
        try:
            out.append(fn(*items))  # type: ignore[operator]
        except Exception:
            return None  # (the column raises too)
    return out


def _agrees(column: Callable[[], list[float | None]], *shown: object) -> None:
    """``column()`` gives the floats of :func:`_one_by_one` over ``shown`` (the table and its
    input columns), or raises where that fails."""
    table, *inputs = shown
    expected = _one_by_one(table, *inputs)  # type: ignore[arg-type]
    try:
        got = column()
    except (IndexError, ValueError):
        assert expected is None, inputs
        return
    assert expected is not None and _same(got, expected), (*inputs, got, expected)


@given(
    curve=curves(),
    pool=st.lists(some, min_size=1, max_size=8),
    picks=st.lists(st.integers(0, 7), max_size=40),
    nan=st.booleans(),
)
def test_a_curve_column_is_the_curve_value_by_value(
    curve: Curve, pool: list[float | None], picks: list[int], nan: bool
) -> None:
    values = [pool[k % len(pool)] for k in picks] + ([math.nan] if nan else [])
    _agrees(lambda: curve_column(curve)(values), curve, values)


@given(
    params=points,
    data=st.data(),
    pairs=st.lists(st.tuples(st.integers(0, 5), st.integers(0, 5)), max_size=40),
    xs=st.lists(some, min_size=6, max_size=6),
    ps=st.lists(st.one_of(finite, special, st.none(), st.just(math.nan)), min_size=6, max_size=6),
)
def test_a_surface_column_is_the_surface_value_by_value(
    params: list[float],
    data: st.DataObject,
    pairs: list[tuple[int, int]],
    xs: list[float | None],
    ps: list[float | None],
) -> None:
    surface = Surface(tuple(params), tuple(data.draw(curves()) for _ in params))
    column_x = [xs[i] for i, _ in pairs]
    column_p = [ps[j] for _, j in pairs]
    _agrees(lambda: surface_column(surface)(column_x, column_p), surface, column_x, column_p)


@given(
    curve=curves(),
    pool=st.lists(some, min_size=1, max_size=8),
    first=st.lists(st.integers(0, 7), max_size=40),
    second=st.lists(st.integers(0, 7), max_size=40),
)
def test_a_curve_column_remembers_from_column_to_column(
    curve: Curve, pool: list[float | None], first: list[int], second: list[int]
) -> None:
    """The values a column remembers serve the next columns (a stretch after another)."""
    column = curve_column(curve)
    for picks in (first, second, first):
        values = [pool[k % len(pool)] for k in picks]
        _agrees(lambda: column(values), curve, values)  # noqa: B023 (called at once)


@given(
    params=points,
    data=st.data(),
    xs=st.lists(some, min_size=1, max_size=80),
    runs=st.lists(
        st.tuples(st.one_of(finite, special, st.just(math.nan)), st.integers(1, 30)), max_size=6
    ),
)
def test_a_surface_column_over_a_slow_parameter(
    params: list[float],
    data: st.DataObject,
    xs: list[float | None],
    runs: list[tuple[float, int]],
) -> None:
    """A parameter that stays for many samples (a temperature): the column run by run."""
    surface = Surface(tuple(params), tuple(data.draw(curves()) for _ in params))
    column_p: list[float | None] = [p for p, length in runs for _ in range(length)]
    column_x = [xs[k % len(xs)] for k in range(len(column_p))]
    _agrees(lambda: surface_column(surface)(column_x, column_p), surface, column_x, column_p)


@given(
    ends=st.lists(finite, min_size=2, max_size=2, unique=True).map(sorted),
    ys=st.lists(st.one_of(finite, special), min_size=2, max_size=2),
    fractions=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=40),
    nan_at=st.one_of(st.none(), st.integers(0, 40)),
    none_at=st.one_of(st.none(), st.integers(0, 40)),
)
def test_a_line_over_values_between_its_points(
    ends: list[float],
    ys: list[float],
    fractions: list[float],
    nan_at: int | None,
    none_at: int | None,
) -> None:
    """A two-point table over values between its points (issue 24, sixth round: the
    interpolation alone once min and max lie inside), its points themselves, and a NaN
    anywhere among them (min and max may pass over it: the column raises as Curve)."""
    x0, x1 = ends
    curve = Curve((x0, x1), (ys[0], ys[1]))
    values: list[float | None] = [min(x1, max(x0, x0 + (x1 - x0) * f)) for f in fractions]
    if nan_at is not None:
        values.insert(min(nan_at, len(values)), math.nan)
    if none_at is not None:
        values.insert(min(none_at, len(values)), None)
    _agrees(lambda: curve_column(curve)(values), curve, values)

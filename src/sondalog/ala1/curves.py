"""Conversion tables over a column of values (issue 24; §6.5.12, §10).

:class:`~sondalog.protocol.tables.Curve` and :class:`~sondalog.protocol.tables.Surface` look up
one value at a time. Here the same interpolation for a whole series of values (the readings of
one channel over a stretch of sampling instants, :mod:`sondalog.ala1.series`) in list
comprehensions: each segment's differences taken once, a value that repeats (an ADC has 4096
levels, a DS18B20 steps by 1/16 °C) computed once and remembered for the next stretches.
The very floats of the tables, and an exception where they raise (a NaN), for the caller to
compute value by value.
"""

from __future__ import annotations

import bisect
import itertools
from collections.abc import Callable
from typing import Any

from sondalog.protocol.tables import Curve, Surface

Value = float | None
#: A table over a column (None stays None).
CurveColumn = Callable[[list[Value]], list[Value]]
#: Values remembered per table and channel (a fleet of loggers holds many: a bound).
MEMO = 2048


def curve_column(curve: Curve) -> CurveColumn:
    """``curve(x)`` of each value; None stays None."""
    xs, ys = curve.xs, curve.ys
    x_first, x_last, y_first, y_last = xs[0], xs[-1], ys[0], ys[-1]
    # by bisect_right's index i (1 .. len - 1): the segment from point i - 1 to point i
    x0s = (0.0, *xs[:-1])
    y0s = (0.0, *ys[:-1])
    dys = (0.0, *(ys[i] - ys[i - 1] for i in range(1, len(ys))))
    dxs = (1.0, *(xs[i] - xs[i - 1] for i in range(1, len(xs))))
    right = bisect.bisect_right
    if len(xs) == 2:  # a line: no segment to look for, nothing worth remembering
        dy, dx = dys[1], dxs[1]

        def inside(values: list[float]) -> list[float]:
            # (every value between the two points: the interpolation alone; a NaN goes
            # the general way, which raises as Curve does)
            if values and x_first < min(values) and max(values) < x_last:
                total = sum(values)
                if total == total:  # (no NaN: no infinity passes the bounds)
                    return [y_first + dy * (x - x_first) / dx for x in values]
            return [
                y_first
                if x <= x_first
                else y_first + dy * (x - x_first) / dx
                if x < x_last
                else y_last
                if x >= x_last
                else _no_segment(x)  # (a NaN, as Curve raises)
                for x in values
            ]

        def line(values: list[Value]) -> list[Value]:
            return _over_valid(inside, values)

        return line

    def direct(values: list[float]) -> list[float]:
        at = [right(xs, x) for x in values]  # (a NaN: len(xs), no segment: IndexError)
        return [
            y_first
            if x <= x_first
            else y_last
            if x >= x_last
            else y0s[i] + dys[i] * (x - x0s[i]) / dxs[i]
            for x, i in zip(values, at, strict=True)
        ]

    memo: dict[float, float] = {}  # (kept from stretch to stretch: readings come back;
    # never a zero: 0.0 and -0.0 are one key and may give different signs)

    def remembered(values: list[float]) -> list[float]:
        try:  # (most stretches meet only readings met before)
            return [memo[x] for x in values]
        except KeyError:
            pass
        distinct = set(values)
        if 0.0 in distinct:  # (0.0 and -0.0 are one key and may give different signs)
            return direct(values)
        new = [x for x in distinct if x not in memo]
        if new:
            if len(memo) + len(new) > MEMO:
                memo.clear()
                new = list(distinct)
            memo.update(zip(new, direct(new), strict=True))  # (a NaN raises: not kept)
        return [memo[x] for x in values]

    def column(values: list[Value]) -> list[Value]:
        return _over_valid(remembered, values)

    return column


def surface_column(surface: Surface) -> Callable[[list[Value], list[Value]], list[Value]]:
    """``surface(x, p)`` of each pair (None when either is None): the pairs grouped by the
    curves their parameter falls between, each group's curves as columns."""
    params = surface.params
    curves = [curve_column(c) for c in surface.curves]
    p_first, p_last = params[0], params[-1]
    right = bisect.bisect_right

    def group(key: int, xs: list[Value], ps: list[float]) -> list[Value]:
        if key == -1:
            return curves[0](xs)
        if key == -2:
            return curves[-1](xs)
        p0, p1 = params[key - 1], params[key]  # (a NaN parameter: IndexError, as in Surface)
        y0s, y1s = curves[key - 1](xs), curves[key](xs)
        dp = p1 - p0  # (the same float for every pair)
        return [
            y0 + (y1 - y0) * (p - p0) / dp  # type: ignore[operator]
            for y0, y1, p in zip(y0s, y1s, ps, strict=True)
        ]

    def keys_of(ps: list[Any]) -> list[int]:
        # -1: at or below the first parameter, -2: at or above the last, else bisect_right
        if len(params) == 3:  # (bisect_right written out; a NaN: 3, as bisect_right)
            p1 = params[1]
            return [
                -1 if p <= p_first else -2 if p >= p_last else 1 if p < p1 else 2 if p >= p1 else 3
                for p in ps
            ]
        return [-1 if p <= p_first else -2 if p >= p_last else right(params, p) for p in ps]

    def valid_pairs(xs: list[Any], ps: list[Any]) -> list[Value]:
        keys = keys_of(ps)
        runs = [(key, len(list(same))) for key, same in itertools.groupby(keys)]
        if len(runs) == 1:
            return group(keys[0], xs, ps)
        if len(runs) * 16 <= len(keys):  # a parameter that moves slowly: run by run
            out: list[Value] = []
            start = 0
            for key, length in runs:
                end = start + length
                out += group(key, xs[start:end], ps[start:end])
                start = end
            return out
        out = [None] * len(xs)
        for key in set(keys):
            index = [k for k, of in enumerate(keys) if of == key]
            got = group(key, [xs[k] for k in index], [ps[k] for k in index])
            for k, y in zip(index, got, strict=True):
                out[k] = y
        return out

    def column(xs: list[Value], ps: list[Value]) -> list[Value]:
        if not has_none(xs) and not has_none(ps):
            return valid_pairs(xs, ps)
        index = [
            k
            for k, (x, p) in enumerate(zip(xs, ps, strict=True))
            if x is not None and p is not None
        ]
        got = valid_pairs([xs[k] for k in index], [ps[k] for k in index])
        out: list[Value] = [None] * len(xs)
        for k, y in zip(index, got, strict=True):
            out[k] = y
        return out

    return column


def has_none(values: list[Any]) -> bool:
    """Whether ``values`` holds a None (no value): summed in C where it holds only numbers,
    several times faster than ``None in values`` (each float compared with None)."""
    try:
        sum(values, 0.0)  # (None raises a TypeError)
    except Exception:
        return None in values
    return False


def _no_segment(x: float) -> float:
    raise IndexError(f"no segment of the table holds {x!r}")


def _over_valid(fn: Callable[[list[Any]], list[Any]], values: list[Value]) -> list[Value]:
    """``fn`` of the values that are not None, in their places; None stays None."""
    if not has_none(values):
        return fn(values)
    index = [k for k, x in enumerate(values) if x is not None]
    out: list[Value] = [None] * len(values)
    for k, y in zip(index, fn([values[k] for k in index]), strict=True):
        out[k] = y
    return out

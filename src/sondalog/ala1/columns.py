"""Channel values over a series of sampling instants, input by input (issue 24).

:meth:`~sondalog.ala1.measure.Measurer.value` computes one channel at one instant: the
reading of its input(s) (§6.4.4 device calibration), ``cal2`` (§6.5.11), table 1 (1-D, or
2-D for type 9, §6.5.12, §10), ``cal`` (§6.5.10) and table 2. Here the same computation is
split in two for many instants at once: each input's readings as a column (an input shared by
several channels is read once per instant, as the instant memo of the measurer does), then
each channel's values from its columns, with the very floats in the very order of
:meth:`~sondalog.ala1.measure.Measurer.value`. The tables are looked up once per series.

A reading or a computation that raises is that channel's "no valid value" at that instant,
as in the event-by-event path: the exception is kept (:class:`Column.faults`) for the
channel's fault log.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from sondalog.ala1.curves import curve_column, has_none, surface_column
from sondalog.ala1.hardware import SUPPLY_DIVIDER, Hardware
from sondalog.ala1.measure import TIMER_MAX_HZ, ChannelConfig, Input, Measurer
from sondalog.protocol.tables import Curve, Surface, TableError

Value = float | None
#: A channel's value from its inputs' readings (one or two).
Calc = Callable[..., Value]


@dataclass
class Column:
    """Readings (or values) of the instants of a series; ``faults``: index -> exception."""

    values: list[Value]
    faults: dict[int, Exception] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Source:
    """One input of a channel as a column: ``key`` names what channels may share.

    ``read`` reads one host time (and window, for pulses); ``column`` reads many at once
    where the hardware offers it (:class:`ColumnHardware`)."""

    key: Hashable
    read: Callable[..., Value] | None  # None: the input reads ``constant`` (device 0...)
    constant: Value = None
    windowed: bool = False  # pulses: ``read(t, window)``
    column: Callable[[list[float]], list[Value]] | None = None
    counts: Callable[[list[float], list[int]], list[Value]] | None = None  # pulses at once


class ColumnHardware(Protocol):
    """Hardware that reads an input at many host times at once, the outputs as they are
    (the simulation): the very values of its one-time reads."""

    # (each reading r as r * mult + add: a device calibration; the supply's times ``then``)
    def adc_column(
        self, device: int, address: int, times: list[float], mult: float, add: float
    ) -> list[Value]: ...
    def ds18b20_column(
        self, pin: int, rom: int, times: list[float], mult: float, add: float
    ) -> list[Value]: ...
    def supply_column(
        self, times: list[float], mult: float, add: float, then: float
    ) -> list[Value]: ...
    def gsm_column(self, what: str, times: list[float]) -> list[Value]: ...
    def pulses_column(
        self, device: int, address: int, timer: bool, starts: list[float], ends: list[float]
    ) -> list[int]: ...


def affine(values: list[Value], mult: float, add: float, fresh: bool = False) -> list[Value]:
    """``v * mult + add`` of each value (None stays None), a new list (or ``values`` itself
    when it is ``fresh``: made for this call, or only read): the values themselves where
    that is the same float (``* 1.0 + 0.0`` changes only a -0.0, to 0.0)."""
    if mult == 1.0 and add == 0.0 and all(values):  # (no zero of either sign, nor a None:
        return values if fresh else list(values)  # each truth tested in C, not compared)
    return [None if v is None else v * mult + add for v in values]


def mapped(fn: Callable[..., Value], *columns: Sequence[Value]) -> Column:
    """``fn`` over the columns element by element; an element that raises is a fault."""
    try:
        if len(columns) == 1:
            return Column([fn(x) for x in columns[0]])
        return Column([fn(*items) for items in zip(*columns, strict=True)])
    except Exception:
        pass
    out: list[Value] = []
    faults: dict[int, Exception] = {}
    for k, items in enumerate(zip(*columns, strict=True)):
        try:
            out.append(fn(*items))
        except Exception as exc:
            out.append(None)
            faults[k] = exc
    return Column(out, faults)


def remembered(fn: Callable[[Value], Value]) -> Callable[[Value], Value]:
    """``fn`` of a reading that repeats (an ADC has 4096 levels, a DS18B20 steps by 1/16 °C),
    each distinct reading computed once per series. Zeros are computed every time (0.0 and
    -0.0 are one key, and may give values of different signs)."""
    memo: dict[Value, Value] = {}

    def cached(reading: Value) -> Value:
        if reading in memo:
            return memo[reading]
        value = fn(reading)
        if reading:  # (None and zeros are not remembered)
            if len(memo) >= _MEMO:
                memo.clear()
            memo[reading] = value
        return value

    return cached


_MEMO = 16384


def source(measurer: Measurer, cfg: ChannelConfig, inp: Input, number: int) -> Source:
    """How :meth:`Measurer.reading` reads ``inp`` of channel ``cfg`` (input ``number``)."""
    hw: Hardware = measurer.hardware
    many: ColumnHardware | None = hw if hasattr(hw, "adc_column") else None  # type: ignore[assignment]
    if inp.device == 0:
        return Source(("zero",), None, 0.0)
    kind, device_type = cfg.type, inp.device_type
    dm, da = inp.device_mult, inp.device_add
    if kind == 3 or kind == 9:
        if device_type == "MSP430ADC":
            adc, device, address = hw.adc, inp.device, inp.address

            def analog(t: float) -> Value:
                raw = adc(device, address, t)
                return None if raw is None else raw * dm + da

            column = None
            if many is not None:
                column = functools.partial(many.adc_column, device, address, mult=dm, add=da)
            return Source(("adc", device, address, dm, da), analog, column=column)
        if device_type == "DS18B20":
            ds18b20, pin, rom = hw.ds18b20, inp.device_address, inp.address

            def thermometer(t: float) -> Value:
                found = ds18b20(pin, rom, t)
                return None if found is None else found[1] * dm + da

            column = None
            if many is not None:
                column = functools.partial(many.ds18b20_column, pin, rom, mult=dm, add=da)
            return Source(("ds18b20", pin, rom, dm, da), thermometer, column=column)
        return Source(("none",), None, None)
    if kind == 1:
        if device_type != "MSP430ADC":
            return Source(("none",), None, None)
        supply = hw.supply

        def supplied(t: float) -> Value:
            raw = supply(t)
            return None if raw is None else (raw * dm + da) * SUPPLY_DIVIDER

        column = None
        if many is not None:
            column = functools.partial(many.supply_column, mult=dm, add=da, then=SUPPLY_DIVIDER)
        return Source(("supply", dm, da), supplied, column=column)
    timer = device_type == "MSP430TA"  # types 2 and 6: pulses in the window
    if not timer and device_type != "MSP430ADC":
        return Source(("none",), None, None)
    pulses, device, address = hw.pulses, inp.device, inp.address
    limit = TIMER_MAX_HZ if timer else measurer.timing / 2
    floor = math.floor

    def counted(t: float, window: int) -> Value:
        count = pulses(device, address, timer, t - window, t)
        count = min(count, floor(limit * window))
        return count * dm + da if timer else float(count)

    counts = None
    if many is not None:
        many_pulses = many.pulses_column

        def counts(times: list[float], windows: list[int]) -> list[Value]:
            if len(times) != len(windows):
                raise ValueError("a window for each time")
            starts = list(map(operator.sub, times, windows))  # (t - window)
            got = many_pulses(device, address, timer, starts, times)
            caps = {w: floor(limit * w) for w in set(windows)}  # (most windows: one period)
            least = min(caps.values(), default=0)
            if not any(got) and least >= 0:  # (no pulse: min(0, cap))
                return [0 * dm + da if timer else 0.0] * len(got)
            if got and max(got) <= least:  # (no count capped: min(c, cap) is c)
                if not timer or (dm == 1.0 and da == 0.0):  # (c * 1.0 + 0.0 of an int: float(c))
                    return list(map(float, got))
                return [c * dm + da for c in got]
            if timer:  # (min(c, cap) * dm + da)
                return [
                    (cap if (cap := caps[w]) < c else c) * dm + da
                    for c, w in zip(got, windows, strict=True)
                ]
            return [
                float(cap if (cap := caps[w]) < c else c) for c, w in zip(got, windows, strict=True)
            ]

    # (channels of a cohort with the same window count the same pulses: the series adds it)
    key = ("pulses", device, address, timer, limit, dm, da)
    return Source(key, counted, windowed=True, counts=counts)


def channel_plan(measurer: Measurer, cfg: ChannelConfig) -> tuple[tuple[Source, ...], Calc]:
    """The sources of channel ``cfg`` and how its value follows from their readings."""
    kind = cfg.type
    tables = measurer.tables
    table1 = tables.get(cfg.table1) if cfg.table1 else None
    table2 = tables.get(cfg.table2) if cfg.table2 else None
    mult, add = cfg.mult, cfg.add

    def finish(y: Value) -> Value:  # Measurer._finish
        if y is None:
            return None
        y = y * mult + add
        if table2 is not None:
            if not isinstance(table2, Curve):
                return None
            y = table2(y)
        return y

    def first_table(x: float, p: Value) -> Value:  # Measurer._table1
        if table1 is None:
            return x if p is None else None
        if isinstance(table1, TableError):
            return None
        if p is None:
            return table1(x) if isinstance(table1, Curve) else None
        return table1(x, p) if isinstance(table1, Surface) else None

    if kind == 11 or kind == 12:
        hw = measurer.hardware
        gsm, what = hw.gsm, "credit" if kind == 11 else "signal"

        def network(t: float) -> Value:
            return gsm(what, t)

        many = getattr(hw, "gsm_column", None)
        column = None if many is None else functools.partial(many, what)

        def gsm_value(x: Value) -> Value:
            return None if x is None else finish(first_table(x, None))

        return (Source(("gsm", what), network, column=column),), gsm_value
    first, second = cfg.inputs
    m1, a1 = first.cal2_mult, first.cal2_add
    one = source(measurer, cfg, first, 1)
    if kind == 9:
        m2, a2 = second.cal2_mult, second.cal2_add

        memo: dict[tuple[float, float], Value] = {}

        def two_d(r: Value, r2: Value) -> Value:
            if r is None or r2 is None:
                return None
            key = (r, r2)
            if key in memo:
                return memo[key]
            value = finish(first_table(r * m1 + a1, r2 * m2 + a2))
            if r and r2:  # (as :func:`remembered`)
                if len(memo) >= _MEMO:
                    memo.clear()
                memo[key] = value
            return value

        return (one, source(measurer, cfg, second, 2)), two_d
    if table1 is None and table2 is None:

        def plain(r: Value) -> Value:
            return None if r is None else (r * m1 + a1) * mult + add

        return (one,), plain

    def tabled(r: Value) -> Value:
        return None if r is None else finish(first_table(r * m1 + a1, None))

    return (one,), remembered(tabled)


#: A channel's values from its inputs' readings (one list per input), a whole series at once.
Many = Callable[..., list[Value]]


def channel_column(measurer: Measurer, cfg: ChannelConfig) -> Many | None:
    """The values of channel ``cfg`` from its sources' readings (:func:`channel_plan`) as
    list comprehensions, without a call per value: the very floats of its calculation, or an
    exception (the caller then computes value by value). None: a channel whose tables are
    missing or of the wrong kind (value by value, as :func:`channel_plan`)."""
    kind = cfg.type
    tables = measurer.tables
    table1 = tables.get(cfg.table1) if cfg.table1 else None
    table2 = tables.get(cfg.table2) if cfg.table2 else None
    if (table1 is not None and not isinstance(table1, Curve | Surface)) or (
        table2 is not None and not isinstance(table2, Curve)
    ):
        return None
    mult, add = cfg.mult, cfg.add
    second = None if table2 is None else curve_column(table2)

    def finish(ys: list[Value], fresh: bool = True) -> list[Value]:  # (channel_plan's)
        ys = affine(ys, mult, add, fresh)
        return ys if second is None else second(ys)

    if kind == 11 or kind == 12:  # (gsm_value: a 1-D table, or none)
        if isinstance(table1, Surface):
            return None
        if table1 is None:
            return lambda xs: finish(xs, False)  # (the source's own column)
        gsm_table = curve_column(table1)
        return lambda xs: finish(gsm_table(xs))
    m1, a1 = cfg.inputs[0].cal2_mult, cfg.inputs[0].cal2_add
    if kind == 9:
        if not isinstance(table1, Surface):
            return None
        m2, a2 = cfg.inputs[1].cal2_mult, cfg.inputs[1].cal2_add
        surface = surface_column(table1)

        def two_d(rs: list[Value], r2s: list[Value]) -> list[Value]:
            return finish(surface(affine(rs, m1, a1, True), affine(r2s, m2, a2, True)))

        return two_d
    if isinstance(table1, Surface):
        return None
    first = None if table1 is None else curve_column(table1)

    def one_d(rs: list[Value]) -> list[Value]:
        if first is None:
            return finish(affine(rs, m1, a1))
        return finish(first(affine(rs, m1, a1, True)))  # (the table only reads it)

    if first is None and second is None:

        def plain(rs: list[Value]) -> list[Value]:  # (channel_plan's plain)
            if m1 == 1.0 and a1 == 0.0 and all(rs):  # (no zero, no None: as affine)
                return affine(rs, mult, add)  # (r * 1.0 + 0.0 is r, but for -0.0)
            if m1 == mult == 1.0 and a1 == add == 0.0 and not has_none(rs):  # (counts: zeros)
                return [r + 0.0 for r in rs]  # type: ignore[operator]  # (-0.0 to 0.0 alone)
            return [None if r is None else (r * m1 + a1) * mult + add for r in rs]

        return plain
    return one_d

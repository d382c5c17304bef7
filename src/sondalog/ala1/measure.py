"""Measuring a channel (§6.4, §6.5, spec notes §7).

The pipeline: device reading(s) -> device calibration (§6.4.4) -> ``cal2`` per input
(§6.5.11) -> table 1, 1-D or 2-D for type 9 (§6.5.12, §10) -> ``cal`` (§6.5.10.4) -> table 2
-> the channel's format (§6.5.7). ``device 0`` reads 0. Any missing piece (nothing
connected, a sensor without power, a missing or malformed table) gives no value (None).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from decimal import Decimal
from typing import Protocol

from sondalog.ala1.hardware import SUPPLY_DIVIDER, Hardware
from sondalog.ala1.model import View
from sondalog.ala1.rendering import HALF_EVEN, NEAR_BELOW, SCALES, fixed, render
from sondalog.ala1.tokens import NUMBER_LIMIT, NumberFormat, period_seconds
from sondalog.protocol.tables import Curve, Surface, TableError, TableSet

#: Highest countable frequency of the MSP430TA input (§6.5.6.2.2).
TIMER_MAX_HZ = 50_000.0


@dataclass(frozen=True, slots=True)
class Input:
    """One signal input of a channel (two for type 9, §6.5.12.2)."""

    device: int
    address: int
    device_type: str
    device_address: int
    device_mult: float
    device_add: float
    cal2_mult: float
    cal2_add: float
    switch_output: int
    switch_advance: int


@dataclass(frozen=True, slots=True)
class ChannelConfig:
    """A channel's parameters, parsed once per change."""

    number: int
    type: int
    inputs: tuple[Input, Input]
    table1: str
    table2: str
    mult: float
    add: float
    format: NumberFormat
    period: int  # seconds; 0 = not sampled
    start: str  # YYYYMMDDhhmmss
    average: int
    change: Decimal
    samples: int
    used_inputs: tuple[Input, ...] = ()  # the inputs this channel type reads
    switches: tuple[tuple[int, int], ...] = ()  # (output, advance) of switched inputs


def _used(kind: int, inputs: tuple[Input, Input]) -> tuple[Input, ...]:
    if kind in (11, 12):
        return ()
    return inputs if kind == 9 else inputs[:1]


def channel_config(view: View, ch: int) -> ChannelConfig:
    """Read channel ``ch``'s configuration from the parameters."""
    p = f"channel {ch} "

    def slot(name: str, n: int) -> str:
        return view.get(p + name + ("" if n == 1 else " #2"))

    inputs = []
    for n in (1, 2):
        device = int(slot("device", n))
        dev = f"device {device} " if device else ""
        inputs.append(
            Input(
                device=device,
                address=int(slot("address", n)),
                device_type=view.get(dev + "type") if device else "",
                device_address=int(view.get(dev + "address")) if device else 0,
                device_mult=float(view.get(dev + "cal mult")) if device else 1.0,
                device_add=float(view.get(dev + "cal add")) if device else 0.0,
                cal2_mult=float(slot("cal2 mult", n)),
                cal2_add=float(slot("cal2 add", n)),
                switch_output=int(slot("switch output", n)),
                switch_advance=int(slot("switch advance", n)),
            )
        )
    kind = int(view.get(p + "type"))
    pair = (inputs[0], inputs[1])
    used = _used(kind, pair)
    return ChannelConfig(
        number=ch,
        type=kind,
        inputs=pair,
        used_inputs=used,
        switches=tuple((i.switch_output, i.switch_advance) for i in used if i.switch_output),
        table1=view.get(p + "convert 1 file name"),
        table2=view.get(p + "convert 2 file name"),
        mult=float(view.get(p + "cal mult value")),
        add=float(view.get(p + "cal add value")),
        format=NumberFormat.parse(view.get(p + "format")),
        period=period_seconds(view.get(p + "sampling period")) or 0,
        start=view.get(p + "sampling start"),
        average=int(view.get(p + "average samples")),
        change=Decimal(view.get(p + "record change")),
        samples=int(view.get(p + "record samples")),
    )


#: The raw reading of a :meth:`Measurer.direct` channel at a host time; None: no reading.
Reading = Callable[[float], float | None]
#: The value of a raw reading (:meth:`Measurer.parts`).
Calibration = Callable[[float], float]


class Direct(Protocol):
    """A channel's value at host time ``t`` (:meth:`Measurer.direct`)."""

    def __call__(self, t: float, window: float = 0.0, /) -> float | None: ...


class Measurer:
    """Turns hardware readings into channel values."""

    #: False: scheduled samples take the interpreted path (:meth:`value`, one hardware
    #: reading per channel), the reference the fast path is compared with (tests).
    fast = True

    def __init__(self, hardware: Hardware, timing: int = 8) -> None:
        self.hardware = hardware
        self.tables = TableSet()
        self.timing = timing  # global timing (§6.17.2)
        #: Readings of one sampling instant, by input (issue 11): channels that share an
        #: input ask the hardware once. Only between :meth:`begin_instant` and
        #: :meth:`end_instant`, where nothing switches.
        self._memo: dict[tuple[int, int], float | None] | None = None

    def begin_instant(self) -> None:
        if self.fast:
            self._memo = {}

    def end_instant(self) -> None:
        self._memo = None

    def _adc(self, device: int, address: int, t: float) -> float | None:
        memo = self._memo
        if memo is None:
            return self.hardware.adc(device, address, t)
        key = (device, address)  # one instant: one t
        if key in memo:
            return memo[key]
        raw = memo[key] = self.hardware.adc(device, address, t)
        return raw

    def compiled(self, cfg: ChannelConfig) -> Callable[[float, float], float | None]:
        """:meth:`value` for ``cfg`` as one function (issue 11: scheduled sampling): the
        common analog or supply channel without tables through :meth:`direct`, every other
        channel through :meth:`value`."""
        direct = self.direct(cfg)
        if direct is None:
            return lambda t, window: self.value(cfg, t, window)
        return direct

    def _is_direct(self, cfg: ChannelConfig) -> bool:
        first = cfg.inputs[0]
        return (
            self.fast
            and cfg.type in (1, 3)
            and not cfg.table1
            and not cfg.table2
            and first.device != 0
            and first.device_type == "MSP430ADC"
        )

    def parts(self, cfg: ChannelConfig) -> tuple[Reading, Calibration] | None:
        """A :meth:`direct` channel in two parts: its raw reading at a host time (an ADC
        fraction) and the value of a raw reading, for a caller that keeps what it made of
        each raw reading (on-demand reads: an ADC has 4096 levels); None otherwise."""
        if not self._is_direct(cfg):
            return None
        first = cfg.inputs[0]
        device_mult, device_add = first.device_mult, first.device_add
        cal2_mult, cal2_add = first.cal2_mult, first.cal2_add
        mult, add = cfg.mult, cfg.add
        if cfg.type == 1:

            def battery(raw: float) -> float:
                r = (raw * device_mult + device_add) * SUPPLY_DIVIDER
                x = r * cal2_mult + cal2_add
                return x * mult + add

            return self.hardware.supply, battery

        def analog(raw: float) -> float:  # (as :meth:`direct`'s analog)
            r = raw * device_mult + device_add
            x = r * cal2_mult + cal2_add
            return x * mult + add

        return functools.partial(self.hardware.adc, first.device, first.address), analog

    def direct(self, cfg: ChannelConfig) -> Direct | None:
        """:meth:`value` of an analog (type 3) or supply (type 1) channel without tables,
        read through the internal ADC, as one function of the host time (the window is for
        pulses: unused) that computes the same floats in the same order without
        interpreting the configuration; None for every other channel (issue 11)."""
        parts = self.parts(cfg)
        if parts is None:
            return None
        if cfg.type == 1:
            supply, battery = parts

            def supplied(t: float, window: float = 0.0) -> float | None:
                raw = supply(t)
                return None if raw is None else battery(raw)

            return supplied
        first = cfg.inputs[0]
        device_mult, device_add = first.device_mult, first.device_add
        cal2_mult, cal2_add = first.cal2_mult, first.cal2_add
        mult, add = cfg.mult, cfg.add
        device, address = first.device, first.address
        read = self.hardware.adc
        key = (device, address)
        measurer = self

        def analog(t: float, window: float = 0.0) -> float | None:
            # Scheduled sampling runs this for every sample: the reading (one per input and
            # instant) and :meth:`parts`' calibration in one function.
            memo = measurer._memo
            if memo is None:
                raw = read(device, address, t)
            elif key in memo:
                raw = memo[key]
            else:
                raw = memo[key] = read(device, address, t)
            if raw is None:
                return None
            r = raw * device_mult + device_add
            x = r * cal2_mult + cal2_add
            return x * mult + add

        return analog

    def reading(self, cfg: ChannelConfig, inp: Input, t: float, window: float) -> float | None:
        """One input after the device calibration; ``window`` = counting time for pulses."""
        hw = self.hardware
        if inp.device == 0:
            return 0.0
        kind = cfg.type
        device_type = inp.device_type
        if kind == 3 or kind == 9:
            if device_type == "MSP430ADC":
                raw = self._adc(inp.device, inp.address, t)
            elif device_type == "DS18B20":
                found = hw.ds18b20(inp.device_address, inp.address, t)
                raw = None if found is None else found[1]
            else:
                return None
            return None if raw is None else raw * inp.device_mult + inp.device_add
        if kind == 1:
            raw = hw.supply(t) if device_type == "MSP430ADC" else None
            if raw is None:
                return None
            return (raw * inp.device_mult + inp.device_add) * SUPPLY_DIVIDER
        # types 2 and 6: pulses in the window
        timer = device_type == "MSP430TA"
        if not timer and device_type != "MSP430ADC":
            return None
        count = hw.pulses(inp.device, inp.address, timer, t - window, t)
        limit = TIMER_MAX_HZ if timer else self.timing / 2
        count = min(count, math.floor(limit * window))
        return count * inp.device_mult + inp.device_add if timer else float(count)

    def value(self, cfg: ChannelConfig, t: float, window: float) -> float | None:
        """The channel's value at host time ``t`` (unformatted), or None."""
        kind = cfg.type
        if kind == 11 or kind == 12:
            x = self.hardware.gsm("credit" if kind == 11 else "signal", t)
            return None if x is None else self._finish(cfg, self._table1(cfg, x, None))
        first = cfg.inputs[0]
        r = self.reading(cfg, first, t, window)
        if r is None:
            return None
        x = r * first.cal2_mult + first.cal2_add
        if kind == 9:
            second = cfg.inputs[1]
            r2 = self.reading(cfg, second, t, window)
            if r2 is None:
                return None
            return self._finish(cfg, self._table1(cfg, x, r2 * second.cal2_mult + second.cal2_add))
        if not cfg.table1 and not cfg.table2:
            return x * cfg.mult + cfg.add
        return self._finish(cfg, self._table1(cfg, x, None))

    def _table1(self, cfg: ChannelConfig, x: float, p: float | None) -> float | None:
        if not cfg.table1:
            return x if p is None else None  # type 9 needs its 2-D table
        table = self.tables.get(cfg.table1)
        if isinstance(table, TableError):
            return None
        if p is None:
            return table(x) if isinstance(table, Curve) else None
        return table(x, p) if isinstance(table, Surface) else None

    def _finish(self, cfg: ChannelConfig, y: float | None) -> float | None:
        if y is None:
            return None
        y = y * cfg.mult + cfg.add
        if cfg.table2:
            table = self.tables.get(cfg.table2)
            if not isinstance(table, Curve):
                return None
            y = table(y)
        return y

    def why_no_value(self, cfg: ChannelConfig) -> str | None:
        """The table problem that keeps a channel from having a value, for host tools."""
        for name, two_d in ((cfg.table1, cfg.type == 9), (cfg.table2, False)):
            if not name:
                continue
            table = self.tables.get(name)
            if isinstance(table, TableError):
                return str(table)
            if isinstance(table, Surface) != two_d:
                return f"table {name}: a {'2-D' if two_d else '1-D'} table is needed"
        return None


_VALUE_LIMIT = float(NUMBER_LIMIT)


def format_value(cfg: ChannelConfig, value: float | None) -> str:
    """A value in the channel's format; no value is an empty field (spec notes §7)."""
    if value is None or not math.isfinite(value) or abs(value) >= _VALUE_LIMIT:
        return ""  # beyond what a reading can show: no valid value (docs/decisions.md)
    fmt = cfg.format
    rendered = _RENDERED.get(fmt.width * 16 + fmt.decimals)
    if rendered is None:
        rendered = _RENDERED[fmt.width * 16 + fmt.decimals] = {}
    text = rendered.get(value)
    if text is None:
        text = fixed(value, fmt.decimals) or render(repr(value), fmt.decimals)
        text = fmt.render(Decimal(repr(value))) if text is None else text.rjust(fmt.width)
        if len(rendered) >= _RENDERED_MAX:
            rendered.clear()
        rendered[value] = text
    return text


def format_values(
    cfg: ChannelConfig, values: Sequence[float | None], fresh: bool = False
) -> list[str]:
    """:func:`format_value` of each of ``values`` (issue 24: a series of samples), the texts
    rendered lately looked up without a call: by the value (unless the values are ``fresh``:
    averages, new floats), else by its units of the last decimal (new floats, seldom new
    units) where rendering.fixed's common case holds, else by :func:`format_value`.

    The units are ``round(value * 10**decimals)`` as a float: adding and subtracting
    :data:`HALF_EVEN` rounds to the nearest integer (half to even, as ``round``) in two float
    operations wherever the product is below 2**51 (here below 2**33)."""
    texts = None if fresh else rendered_lately(cfg, values)
    if texts is None:
        return _by_units_texts(cfg, values)
    try:
        "".join(texts)  # type: ignore[arg-type]  # (a None raises, in one C loop)
    except TypeError:
        pass
    else:
        return texts  # type: ignore[return-value]
    missing = [k for k, text in enumerate(texts) if text is None]
    if len(missing) == len(texts):
        return _by_units_texts(cfg, values)
    for k, text in zip(missing, _by_units_texts(cfg, [values[k] for k in missing]), strict=True):
        texts[k] = text
    return texts  # type: ignore[return-value]


def rendered_lately(cfg: ChannelConfig, values: Sequence[float | None]) -> list[str | None] | None:
    """The texts of ``values`` rendered lately, looked up by the value (None: not lately);
    None when no value of the channel's format was."""
    fmt = cfg.format
    rendered = _RENDERED.get(fmt.width * 16 + fmt.decimals)
    return None if rendered is None else list(map(rendered.get, values))  # type: ignore[arg-type]


def texts_by_units(cfg: ChannelConfig) -> dict[float, str]:
    """The texts rendered lately by their units of the last decimal (a text of the format
    is the one of its units), in the channel's format."""
    return _BY_UNITS.get(cfg.format.width * 16 + cfg.format.decimals) or {}


def _by_units_texts(cfg: ChannelConfig, values: Sequence[float | None]) -> list[str]:
    """:func:`format_values` of values not looked up by the value: by their units of the
    last decimal where rendering.fixed's common case holds, else by :func:`format_value`."""
    fmt = cfg.format
    decimals, width = fmt.decimals, fmt.width
    key = width * 16 + decimals
    by_units = _BY_UNITS.get(key)
    if by_units is None:
        by_units = _BY_UNITS[key] = {}
    known = KNOWN_UNITS.get(decimals)
    if known is None:
        known = KNOWN_UNITS[decimals] = {}
    pattern, ten = f"%d.%0{decimals}d", 10**decimals

    def made(rounded: float) -> str:  # (the text of new units, kept by them)
        units = int(rounded)
        if decimals:  # (whole part, then the decimals zero-padded: one % operation)
            text: str = pattern % divmod(-units if units < 0 else units, ten)
            text = ("-" + text if units < 0 else text).rjust(width)
        else:
            text = str(units).rjust(width)
        if len(by_units) >= _RENDERED_MAX:
            by_units.clear()
        by_units[rounded] = text
        if len(known) >= KNOWN_UNITS_MAX:
            known.clear()
        known[text] = units  # (a text of the format: ``int`` of its digits is ``units``)
        return text

    near, scale, rounds = NEAR_BELOW[decimals], SCALES[decimals], HALF_EVEN
    units_text = by_units.get
    try:  # (every value within the bounds, or a NaN: taken as one below; a None raises)
        within = -near < min(values) and max(values) < near  # type: ignore[operator,type-var]
    except (TypeError, ValueError):  # (no value, or no values)
        within = False
    return [
        text  # type: ignore[misc]  # (a str wherever it is taken)
        if (within or (value is not None and -near < value < near))
        and not -1e-4 < value < 1e-4  # type: ignore[operator]
        and -0.4999
        < (scaled := value * scale) - (units := scaled + rounds - rounds)  # type: ignore[operator]
        < 0.4999
        and ((text := units_text(units)) is not None or (text := made(units)) is not None)
        else format_value(cfg, value)  # (which keeps the text by the value)
        for value in values
    ]


#: Values rendered lately (issue 11): readings repeat (an ADC has 4096 levels), and the
#: decimal rendering costs more than the rest of a measurement. -0.0 and 0.0 share an
#: entry: both render without a sign.
_RENDERED: dict[int, dict[float, str]] = {}  # by width * 16 + decimals
#: The same texts by the value in units of the last decimal (far from a half), as a float.
_BY_UNITS: dict[int, dict[float, str]] = {}
_RENDERED_MAX = 8192
#: Texts in units of their last decimal (None: not a number of the channel's format), by
#: decimals: the texts rendered by units above, and those the record conditions met
#: (:func:`sondalog.ala1.conditions.record_all`: a new text is otherwise matched and parsed).
KNOWN_UNITS: dict[int, dict[str, int | None]] = {}
KNOWN_UNITS_MAX = 8192

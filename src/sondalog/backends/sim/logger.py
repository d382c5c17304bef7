"""Simulated ALA1 hardware (DESIGN.md point 4; docs/simulation.md).

:class:`SimHardware` is the simulation backend of the logger's hardware port: voltages on
ADC inputs, pulse sources, DS18B20 sensors and GSM values, each a signal of
:mod:`sondalog.backends.sim.signals` evaluated at host-clock time. A site file's
``[logger]`` table describes it (:mod:`sondalog.backends.sim.logger_site`).
"""

from __future__ import annotations

import bisect
import itertools
import math
import operator
import random
from dataclasses import dataclass, field

from sondalog.ala1.hardware import (
    ADC_LEVELS,
    DS18B20_SCALE,
    INTERNAL_REFERENCE,
    SUPPLY_DIVIDER,
    normalise,
    pin_of,
)
from sondalog.ala1.rendering import HALF_EVEN
from sondalog.backends.sim.signals import Signal, constant, signal_column


@dataclass
class Analog:
    """A voltage on an ADC input."""

    address: int
    signal: Signal
    power: int | None = None


@dataclass
class PulseSource:
    """Pulses on the timer input or an ADC pin: a steady rate or Poisson bursts."""

    timer: bool
    address: int
    rate: float = 0.0
    burst_rate: float = 0.0
    burst: int = 1
    seed: int = 0
    origin: float = 0.0
    _events: list[float] = field(default_factory=list)
    _rng: random.Random | None = None

    def count(self, t0: float, t1: float) -> int:
        if t1 <= t0:
            return 0
        if self.rate:
            a = math.floor((t0 - self.origin) * self.rate)
            b = math.floor((t1 - self.origin) * self.rate)
            return max(0, b - a)
        if not self.burst_rate:
            return 0
        self._extend(t1)
        events = self._events
        return (bisect.bisect_left(events, t1) - bisect.bisect_left(events, t0)) * self.burst

    def counts(self, starts: list[float], ends: list[float]) -> list[int]:
        """:meth:`count` of each window ``[starts[i], ends[i])``."""
        windows = zip(starts, ends, strict=True)
        if self.rate:
            origin, rate, floor = self.origin, self.rate, math.floor
            return [
                0 if t1 <= t0 else max(0, floor((t1 - origin) * rate) - floor((t0 - origin) * rate))
                for t0, t1 in windows
            ]
        if not self.burst_rate or not ends:
            return [0] * len(ends)
        self._extend(max(ends))
        events, burst, left = self._events, self.burst, bisect.bisect_left
        if left(events, min(starts)) == left(events, max(ends)):  # (no pulse in any window)
            return [0] * len(ends)
        if starts[1:] == ends[:-1] and all(map(operator.le, ends, ends[1:])):
            return _placed(events, starts[0], ends, burst)  # (sampling windows)
        at_ends = _before_each(events, ends)
        if starts[1:] == ends[:-1]:  # (windows one after the other: each start an end before)
            at_starts = [left(events, starts[0]), *at_ends[:-1]]
        else:
            at_starts = [left(events, t0) for t0 in starts]
        return [
            0 if t1 <= t0 else (b - a) * burst
            for t0, t1, a, b in zip(starts, ends, at_starts, at_ends, strict=True)
        ]

    def _extend(self, until: float) -> None:
        if self._rng is None:
            self._rng = random.Random(self.seed)
        last = self._events[-1] if self._events else self.origin
        while last < until:
            last += self._rng.expovariate(self.burst_rate)
            self._events.append(last)


def _placed(events: list[float], start: float, ends: list[float], burst: int) -> list[int]:
    """``burst`` times the events in each window of ``[start, ends[0])``, ``[ends[0],
    ends[1])`` ... (ascending ``ends``: windows one after the other, the first empty if
    ``start`` is not before its end): each event of the span counted once in its window
    (``bisect_right(ends, event)``), not two searches a window (a day of 1-minute windows
    holds a few dozen events)."""
    counts = [0] * len(ends)
    left, right = bisect.bisect_left, bisect.bisect_right
    for event in events[left(events, min(start, ends[0])) : left(events, ends[-1])]:
        counts[right(ends, event)] += burst
    return counts


def _before_each(events: list[float], ends: list[float]) -> list[int]:
    """``bisect_left(events, t)`` of each of ``ends``: when the ends ascend (sampling
    instants), the few events among them placed once each instead of a search per end."""
    left = bisect.bisect_left
    first = left(events, ends[0])
    among = events[first : left(events, ends[-1])]
    if len(among) * 8 > len(ends) or not all(map(operator.le, ends, ends[1:])):
        return [left(events, t) for t in ends]
    steps = [first, *[0] * len(ends)]
    right = bisect.bisect_right
    for event in among:  # (each event counts from the first end above it on)
        steps[right(ends, event)] += 1
    return list(itertools.accumulate(steps))[: len(ends)]


@dataclass
class Thermometer:
    """A DS18B20 on a P6 pin."""

    pin: int
    rom: int
    signal: Signal
    power: int | None = None
    crc_error: bool = False  # its scratchpad fails the CRC: no valid reading (control API)


class SimHardware:
    """The simulation backend of :class:`sondalog.ala1.hardware.Hardware`.

    Tests change the world through its attributes (``analog[16].signal = ...``) or
    :meth:`set_signal`.

    Its readings depend only on the time asked and on which outputs are on, and switching an
    output does nothing else (``pure_readings``): the sampler may read many instants input
    by input (:mod:`sondalog.ala1.series`, issue 24). Change the world between the core's
    calls, not from inside a reading.
    """

    pure_readings = True

    def __init__(
        self,
        *,
        supply: Signal | None = None,
        supply_power: int | None = 1,
        external_reference: float = INTERNAL_REFERENCE,
        analog: list[Analog] | None = None,
        pulses: list[PulseSource] | None = None,
        thermometers: list[Thermometer] | None = None,
        gsm: dict[str, Signal] | None = None,
    ) -> None:
        self.supply_signal: Signal | None = supply
        self.supply_power = supply_power
        self.external_reference = external_reference
        self.analog = {pin_of(a.address): a for a in analog or []}
        self.pulse_sources = pulses or []
        self.thermometers = thermometers or []
        self.gsm_signals = gsm or {}
        self.outputs: dict[int, bool] = {}

    # -- test and control hooks ---------------------------------------------------------------
    def set_signal(self, what: str, signal: Signal | float) -> None:
        """Replace a signal: ``"supply"``, ``"analog:16"``, ``"ds18b20:<rom hex>"``,
        ``"gsm:signal"``, ``"gsm:credit"``. A number means a constant."""
        sig = constant(float(signal)) if isinstance(signal, int | float) else signal
        kind, _, key = what.partition(":")
        if kind == "supply":
            self.supply_signal = sig
        elif kind == "analog":
            self.analog[pin_of(int(key))].signal = sig
        elif kind == "ds18b20":
            next(t for t in self.thermometers if t.rom == int(key, 16)).signal = sig
        elif kind == "gsm":
            self.gsm_signals[key] = sig
        else:
            raise KeyError(what)

    def powered(self, power: int | None) -> bool:
        return power is None or self.outputs.get(power, False)

    # -- Hardware ---------------------------------------------------------------------------
    def adc(self, device: int, address: int, t: float) -> float | None:
        if address >= 32:  # the same pins against the external reference
            source, reference = self.analog.get(address - 16), self.external_reference
        else:
            source, reference = self.analog.get(address), INTERNAL_REFERENCE
        if source is None:
            return None
        power = source.power
        if power is not None and not self.outputs.get(power):
            return None
        # normalise() written out on this hot path; unlike it, a NaN signal raises here
        fraction = source.signal(t) / reference
        if fraction <= 0.0:
            return 0.0
        return 1.0 if fraction >= 1.0 else round(fraction * ADC_LEVELS) / ADC_LEVELS

    def supply(self, t: float) -> float | None:
        if self.supply_signal is None or not self.powered(self.supply_power):
            return None
        return normalise(self.supply_signal(t) / SUPPLY_DIVIDER)

    def pulses(self, device: int, address: int, timer: bool, t0: float, t1: float) -> int:
        total = 0
        for source in self.pulse_sources:
            if source.timer == timer and (timer or pin_of(source.address) == pin_of(address)):
                total += source.count(t0, t1)
        return total

    def ds18b20(self, pin: int, rom: int, t: float) -> tuple[int, float] | None:
        sensor = self._thermometer(pin, rom)
        if sensor is None or sensor.crc_error:  # a bad CRC reads as no answer (control fault)
            return None
        celsius = min(125.0, max(-55.0, sensor.signal(t)))
        return sensor.rom, round(celsius * 16) / 16 / DS18B20_SCALE

    def _thermometer(self, pin: int, rom: int) -> Thermometer | None:
        """The sensor that answers ``rom`` on ``pin`` (None: none, or several at once)."""
        outputs = self.outputs
        sensor: Thermometer | None = None
        if rom == 0 or rom & 0xFF == 0:
            for candidate in self.thermometers:  # the only powered sensor on the pin
                power = candidate.power
                if candidate.pin == pin and (power is None or outputs.get(power, False)):
                    if sensor is not None:
                        return None  # several sensors answering at once
                    sensor = candidate
            return sensor
        for candidate in self.thermometers:
            power = candidate.power
            if (
                candidate.pin == pin
                and candidate.rom == rom
                and (power is None or outputs.get(power, False))
            ):
                return candidate
        return None

    def gsm(self, what: str, t: float) -> float | None:
        signal = self.gsm_signals.get(what)
        return None if signal is None else signal(t)

    # -- many instants at once (sondalog.ala1.columns.ColumnHardware, issue 24) ----------------
    def adc_column(
        self, device: int, address: int, times: list[float], mult: float = 1.0, add: float = 0.0
    ) -> list[float | None]:
        """:meth:`adc` at each of ``times``, the outputs as they are, each reading ``r`` as
        ``r * mult + add`` (a device calibration, in the same pass)."""
        if address >= 32:
            source, reference = self.analog.get(address - 16), self.external_reference
        else:
            source, reference = self.analog.get(address), INTERNAL_REFERENCE
        if source is None or (source.power is not None and not self.outputs.get(source.power)):
            return [None] * len(times)
        levels = ADC_LEVELS
        signals = signal_column(source.signal, times)
        if (
            signals
            and reference > 0.0
            and min(signals) / reference > 0.0
            and max(signals) / reference < 1.0
            and math.isfinite(sum(signals))
        ):  # every fraction within the range (x / reference grows with x), none a NaN:
            # rounded alone (by :data:`HALF_EVEN`), and ``* 1.0 + 0.0`` left off (it
            # changes only a -0.0, and none is made here)
            m = HALF_EVEN
            if mult == 1.0 and add == 0.0:
                return [(x / reference * levels + m - m) / levels for x in signals]
            return [(x / reference * levels + m - m) / levels * mult + add for x in signals]
        # (a NaN raises in round(), as in :meth:`adc`)
        return [
            (
                0.0
                if (f := x / reference) <= 0.0
                else 1.0
                if f >= 1.0
                else round(f * levels) / levels
            )
            * mult
            + add
            for x in signals
        ]

    def ds18b20_column(
        self, pin: int, rom: int, times: list[float], mult: float = 1.0, add: float = 0.0
    ) -> list[float | None]:
        """The normalised reading ``r`` of :meth:`ds18b20` at each of ``times``, as
        ``r * mult + add`` (a device calibration, once per temperature)."""
        sensor = self._thermometer(pin, rom)
        if sensor is None or sensor.crc_error:
            return [None] * len(times)
        scale = DS18B20_SCALE
        celsius = signal_column(sensor.signal, times)
        if (
            celsius
            and min(celsius) > -55.0
            and max(celsius) < 125.0
            and math.isfinite(sum(celsius))
        ):
            # every temperature within the range, none a NaN: rounded alone, and ``* 1.0 +
            # 0.0`` left off (it changes only a -0.0, and none is made here)
            if celsius[0] == max(celsius) == min(celsius):  # (a steady temperature)
                return [round(celsius[0] * 16) / 16 / scale * mult + add] * len(celsius)
            m = HALF_EVEN
            if mult == 1.0 and add == 0.0:
                return [(c * 16 + m - m) / 16 / scale for c in celsius]
            return [(c * 16 + m - m) / 16 / scale * mult + add for c in celsius]
        distinct = set(celsius)  # (a sensor's temperature repeats: each converted once)
        # min(125.0, max(-55.0, c)) written out: the same float, a NaN too (-55.0)
        if len(distinct) * 2 > len(celsius):
            return [
                round((-55.0 if not c > -55.0 else c if c < 125.0 else 125.0) * 16)
                / 16
                / scale
                * mult
                + add
                for c in celsius
            ]
        reading = {
            c: round((-55.0 if not c > -55.0 else c if c < 125.0 else 125.0) * 16)
            / 16
            / scale
            * mult
            + add
            for c in distinct
        }
        return [reading[c] for c in celsius]

    def supply_column(
        self, times: list[float], mult: float = 1.0, add: float = 0.0, then: float = 1.0
    ) -> list[float | None]:
        """:meth:`supply` ``r`` at each of ``times``, as ``(r * mult + add) * then`` (a device
        calibration and the divider, in the same pass)."""
        signal = self.supply_signal
        if signal is None or not self.powered(self.supply_power):
            return [None] * len(times)
        levels, reference = ADC_LEVELS, INTERNAL_REFERENCE  # normalise() written out
        signals = signal_column(signal, times)
        divider = SUPPLY_DIVIDER
        if (
            signals
            and mult == 1.0
            and add == 0.0
            and math.isfinite(sum(signals))
            and (
                min(signals) / divider / reference > 0.0
                and max(signals) / divider / reference < 1.0
            )
        ):
            # (every fraction within the range, none a NaN: rounded alone, ``* 1.0 +
            # 0.0`` left off: it changes only a -0.0, and none is made here)
            m = HALF_EVEN
            return [(x / divider / reference * levels + m - m) / levels * then for x in signals]
        return [
            (
                (
                    1.0
                    if (f := x / SUPPLY_DIVIDER / reference) >= 1.0
                    else round(f * levels) / levels
                    if f > 0.0
                    else 0.0
                )
                * mult
                + add
            )
            * then
            for x in signals
        ]

    def gsm_column(self, what: str, times: list[float]) -> list[float | None]:
        """:meth:`gsm` at each of ``times``."""
        signal = self.gsm_signals.get(what)
        return [None] * len(times) if signal is None else list(signal_column(signal, times))

    def pulses_column(
        self, device: int, address: int, timer: bool, starts: list[float], ends: list[float]
    ) -> list[int]:
        """:meth:`pulses` of each window ``[starts[i], ends[i])``."""
        totals: list[int] | None = None
        for source in self.pulse_sources:
            if source.timer == timer and (timer or pin_of(source.address) == pin_of(address)):
                counted = source.counts(starts, ends)
                if totals is None:
                    totals = counted
                else:
                    totals = [a + b for a, b in zip(totals, counted, strict=True)]
        return [0] * len(ends) if totals is None else totals

    def prepare(self, t: float) -> None:
        """Simulated inputs are there at once: nothing to acquire ahead."""
        return None

    def set_output(self, output: int, on: bool, t: float) -> None:
        self.outputs[output] = on


def default_hardware(start: float) -> SimHardware:
    """The world without a site file: a 12 V supply and nothing else connected."""
    return SimHardware(supply=constant(12.0))

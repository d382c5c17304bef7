"""Simulated ALA1 hardware (DESIGN.md point 4; docs/simulation.md).

:class:`SimHardware` is the simulation backend of the logger's hardware port: voltages on
ADC inputs, pulse sources, DS18B20 sensors and GSM values, each a signal of
:mod:`sondalog.backends.sim.signals` evaluated at host-clock time. A site file's
``[logger]`` table describes it (:mod:`sondalog.backends.sim.logger_site`).
"""

from __future__ import annotations

import bisect
import math
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
from sondalog.backends.sim.signals import Signal, constant


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

    def _extend(self, until: float) -> None:
        if self._rng is None:
            self._rng = random.Random(self.seed)
        last = self._events[-1] if self._events else self.origin
        while last < until:
            last += self._rng.expovariate(self.burst_rate)
            self._events.append(last)


@dataclass
class Thermometer:
    """A DS18B20 on a P6 pin."""

    pin: int
    rom: int
    signal: Signal
    power: int | None = None


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
        outputs = self.outputs
        sensor: Thermometer | None = None
        if rom == 0 or rom & 0xFF == 0:
            for candidate in self.thermometers:  # the only powered sensor on the pin
                power = candidate.power
                if candidate.pin == pin and (power is None or outputs.get(power, False)):
                    if sensor is not None:
                        return None  # several sensors answering at once
                    sensor = candidate
        else:
            for candidate in self.thermometers:
                power = candidate.power
                if (
                    candidate.pin == pin
                    and candidate.rom == rom
                    and (power is None or outputs.get(power, False))
                ):
                    sensor = candidate
                    break
        if sensor is None:
            return None
        celsius = min(125.0, max(-55.0, sensor.signal(t)))
        return sensor.rom, round(celsius * 16) / 16 / DS18B20_SCALE

    def gsm(self, what: str, t: float) -> float | None:
        signal = self.gsm_signals.get(what)
        return None if signal is None else signal(t)

    def prepare(self, t: float) -> None:
        """Simulated inputs are there at once: nothing to acquire ahead."""
        return None

    def set_output(self, output: int, on: bool, t: float) -> None:
        self.outputs[output] = on


def default_hardware(start: float) -> SimHardware:
    """The world without a site file: a 12 V supply and nothing else connected."""
    return SimHardware(supply=constant(12.0))

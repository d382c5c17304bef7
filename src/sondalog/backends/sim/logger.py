"""Simulated ALA1 hardware driven by a site file (DESIGN.md point 4; docs/simulation.md).

The ``[logger]`` part of a site file (TOML) describes what is wired to the module::

    [logger]
    seed = 7                                      # seeds generated ROM codes and bursts
    supply = { model = "constant", value = 12.0 } # volts
    supply_power = 1                              # output powering the supply divider (§6.7.2)
    external_reference = 2.0                      # volts on K2 pin 2 (addresses >= 32)

    [[logger.analog]]                             # a voltage on an MSP430ADC input
    address = 16                                  # the input's internal-reference address
    signal = { model = "sine", mean = 1.0, amplitude = 0.5, period = 86400 }
    power = 2                                     # optional: the output that powers it

    [[logger.pulses]]                             # pulses for type 2 / 6 channels
    timer = true                                  # MSP430TA input P1.0, or: address = 17
    rate = 5.0                                    # Hz, or: poisson = { rate = 0.01, burst = 3 }

    [[logger.ds18b20]]                            # a DS18B20 on P6 bit `pin`
    pin = 4
    rom = "A2000008D5E4FD28"                      # optional, hex; generated from the seed
    signal = { model = "constant", value = 21.5 } # degrees Celsius
    power = 2                                     # optional

    [logger.gsm]
    signal = { model = "constant", value = 18 }   # channel type 12
    credit = { model = "ramp", start = 250, rate = -0.001 }  # channel type 11

Signals are those of :mod:`sondalog.backends.sim.signals`, evaluated at host-clock time. A
wrong file is rejected with a :class:`~sondalog.config.ConfigError` naming file, line and field.
"""

from __future__ import annotations

import bisect
import math
import random
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.ala1.hardware import (
    ADC_LEVELS,
    ANALOG_ADDRESSES,
    DS18B20_SCALE,
    INTERNAL_REFERENCE,
    SUPPLY_DIVIDER,
    normalise,
    pin_of,
    rom_code,
    rom_valid,
)
from sondalog.backends.sim.signals import Signal, SignalError, build_signal, constant
from sondalog.config import ConfigError, locate, read_site_file


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
    """

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
        return sum(
            source.count(t0, t1)
            for source in self.pulse_sources
            if source.timer == timer and (timer or pin_of(source.address) == pin_of(address))
        )

    def ds18b20(self, pin: int, rom: int, t: float) -> tuple[int, float] | None:
        present = [s for s in self.thermometers if s.pin == pin and self.powered(s.power)]
        if rom == 0 or rom & 0xFF == 0:
            if len(present) != 1:
                return None  # nothing there, or several sensors answering at once
            sensor = present[0]
        else:
            found = [s for s in present if s.rom == rom]
            if not found:
                return None
            sensor = found[0]
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


# -- site file -------------------------------------------------------------------------------

_LOGGER_KEYS = {
    "seed",
    "supply",
    "supply_power",
    "external_reference",
    "analog",
    "pulses",
    "ds18b20",
    "gsm",
    "backend",  # read by sondalog serve (app/site.py)
    "serve",
}
_ANALOG_KEYS = {"address", "signal", "power"}
_PULSE_KEYS = {"timer", "address", "rate", "poisson"}
_DS_KEYS = {"pin", "rom", "signal", "power"}


def default_hardware(start: float) -> SimHardware:
    """The world without a site file: a 12 V supply and nothing else connected."""
    return SimHardware(supply=constant(12.0))


def load_logger_site(path: Path, start: float) -> SimHardware:
    """Read the ``[logger]`` part of the site file at ``path``."""
    data, text = read_site_file(path)
    return parse_logger_site(data, start, path, text)


def parse_logger_site(
    data: Mapping[str, object], start: float, path: Path | None = None, text: str | None = None
) -> SimHardware:
    """Build the simulated hardware from an already parsed site file."""

    def fail(where: str, message: str) -> ConfigError:
        return ConfigError(path, where, message, locate(text, where))

    logger = data.get("logger")
    if logger is None:
        return default_hardware(start)
    if not isinstance(logger, Mapping):
        raise fail("logger", "must be a table")
    _known(logger, _LOGGER_KEYS, "logger", fail)
    base = path.parent if path is not None else None

    def signal(table: object, where: str) -> Signal:
        if not isinstance(table, Mapping):
            raise fail(where, "a signal table is required")
        try:
            return build_signal(table, start, base)
        except SignalError as exc:
            raise fail(f"{where}.{exc.field}", exc.message) from None

    def integer(table: Mapping[str, object], key: str, where: str, lo: int, hi: int) -> int:
        value = table.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise fail(f"{where}.{key}", f"must be an integer {lo}..{hi}, not {value!r}")
        return value

    def entries(key: str) -> list[tuple[str, Mapping[str, object]]]:
        raw = logger.get(key, [])
        if not isinstance(raw, list):
            raise fail(f"logger.{key}", f"must be an array of tables ([[logger.{key}]])")
        out = []
        for i, entry in enumerate(raw):
            where = f"logger.{key}[{i}]"
            if not isinstance(entry, Mapping):
                raise fail(where, "must be a table")
            out.append((where, entry))
        return out

    def power(table: Mapping[str, object], where: str) -> int | None:
        return integer(table, "power", where, 1, 7) if "power" in table else None

    seed = integer(logger, "seed", "logger", 0, 2**63) if "seed" in logger else 0
    rng = random.Random(seed)
    supply = signal(logger["supply"], "logger.supply") if "supply" in logger else constant(12.0)
    supply_power = (
        integer(logger, "supply_power", "logger", 1, 7) if "supply_power" in logger else 1
    )
    reference = logger.get("external_reference", INTERNAL_REFERENCE)
    if isinstance(reference, bool) or not isinstance(reference, int | float) or reference <= 0:
        raise fail("logger.external_reference", f"must be volts > 0, not {reference!r}")

    analog: list[Analog] = []
    for where, entry in entries("analog"):
        _known(entry, _ANALOG_KEYS, where, fail)
        address = entry.get("address")
        if address not in ANALOG_ADDRESSES or isinstance(address, bool):
            allowed = ", ".join(map(str, ANALOG_ADDRESSES))
            raise fail(f"{where}.address", f"must be an ADC input address ({allowed})")
        assert isinstance(address, int)
        if any(pin_of(a.address) == pin_of(address) for a in analog):
            raise fail(f"{where}.address", "this input is already described")
        analog.append(
            Analog(address, signal(entry.get("signal"), f"{where}.signal"), power(entry, where))
        )

    pulses: list[PulseSource] = []
    for where, entry in entries("pulses"):
        _known(entry, _PULSE_KEYS, where, fail)
        timer = entry.get("timer", False)
        if not isinstance(timer, bool):
            raise fail(f"{where}.timer", "must be true or false")
        address = 0 if timer else integer(entry, "address", where, 0, 36)
        source = PulseSource(timer, address, seed=rng.randrange(2**32), origin=start)
        if "rate" in entry and "poisson" in entry:
            raise fail(f"{where}.poisson", "give either rate or poisson, not both")
        if "rate" in entry:
            rate = entry["rate"]
            if isinstance(rate, bool) or not isinstance(rate, int | float) or rate < 0:
                raise fail(f"{where}.rate", f"must be pulses per second >= 0, not {rate!r}")
            source.rate = float(rate)
        elif isinstance(entry.get("poisson"), Mapping):
            poisson = entry["poisson"]
            assert isinstance(poisson, Mapping)
            _known(poisson, {"rate", "burst", "seed"}, f"{where}.poisson", fail)
            rate = poisson.get("rate")
            if isinstance(rate, bool) or not isinstance(rate, int | float) or rate <= 0:
                raise fail(f"{where}.poisson.rate", f"must be bursts per second > 0, not {rate!r}")
            source.burst_rate = float(rate)
            source.burst = (
                integer(poisson, "burst", f"{where}.poisson", 1, 10**6) if "burst" in poisson else 1
            )
            if "seed" in poisson:
                source.seed = integer(poisson, "seed", f"{where}.poisson", 0, 2**63)
        else:
            raise fail(where, "needs rate = <Hz> or poisson = { rate = ..., burst = ... }")
        pulses.append(source)

    thermometers: list[Thermometer] = []
    for where, entry in entries("ds18b20"):
        _known(entry, _DS_KEYS, where, fail)
        pin = integer(entry, "pin", where, 0, 7)
        if "rom" in entry:
            raw = entry["rom"]
            if not isinstance(raw, str) or not re.fullmatch(r"(0x)?[0-9A-Fa-f]{16}", raw):
                raise fail(f"{where}.rom", "must be 16 hexadecimal digits")
            rom = int(raw, 16)
            if not rom_valid(rom):
                raise fail(f"{where}.rom", "needs family 0x28 in the lowest byte and a valid CRC-8")
        else:
            rom = rom_code(rng.randrange(2**48))
        if any(t.rom == rom for t in thermometers):
            raise fail(f"{where}.rom", "two sensors with one ROM code")
        thermometers.append(
            Thermometer(
                pin, rom, signal(entry.get("signal"), f"{where}.signal"), power(entry, where)
            )
        )

    gsm: dict[str, Signal] = {}
    raw_gsm = logger.get("gsm", {})
    if not isinstance(raw_gsm, Mapping):
        raise fail("logger.gsm", "must be a table")
    _known(raw_gsm, {"signal", "credit"}, "logger.gsm", fail)
    for key in ("signal", "credit"):
        if key in raw_gsm:
            gsm[key] = signal(raw_gsm[key], f"logger.gsm.{key}")

    return SimHardware(
        supply=supply,
        supply_power=supply_power,
        external_reference=float(reference),
        analog=analog,
        pulses=pulses,
        thermometers=thermometers,
        gsm=gsm,
    )


def _known(table: Mapping[str, object], keys: set[str], where: str, fail: object) -> None:
    for key in table:
        if key not in keys:
            assert callable(fail)
            raise fail(f"{where}.{key}", f"unknown key (known: {', '.join(sorted(keys))})")

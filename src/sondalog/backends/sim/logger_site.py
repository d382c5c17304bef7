"""The ``[logger]`` table of a site file read into a :class:`SimPlan` (docs/simulation.md).

The plan is the parsed, checked description of what is wired to the simulated module; it
is made once when the site file is loaded (``sondalog serve --check`` included) and every
start builds its :class:`~sondalog.backends.sim.logger.SimHardware` from it
(:meth:`SimPlan.build`) without reading the file again::

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

Every table goes through :class:`sondalog.config.Table`: an unknown key is refused with a
"did you mean", a wrong value names file, line and field (:class:`ConfigError`).
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from pathlib import Path

from sondalog.ala1.hardware import ANALOG_ADDRESSES, INTERNAL_REFERENCE, pin_of, rom_code, rom_valid
from sondalog.backends.sim.logger import Analog, PulseSource, SimHardware, Thermometer
from sondalog.backends.sim.signals import Signal, constant, read_signal, shifted
from sondalog.config import Table, load

#: The keys of ``[logger]``; ``backend`` and ``serve`` are read by ``sondalog serve``.
LOGGER_KEYS = (
    "seed",
    "supply",
    "supply_power",
    "external_reference",
    "analog",
    "pulses",
    "ds18b20",
    "gsm",
    "backend",
    "serve",
)
_ANALOG_KEYS = ("address", "signal", "power")
_PULSE_KEYS = ("timer", "address", "rate", "poisson")
_POISSON_KEYS = ("rate", "burst", "seed")
_DS_KEYS = ("pin", "rom", "signal", "power")
_GSM_KEYS = ("signal", "credit")


@dataclass(frozen=True, slots=True)
class SignalPlan:
    """A checked signal, made once at load against origin 0.

    Without an ``origin =`` its times count from the start of the simulation (signals.py),
    so :meth:`at` shifts it to the start: ``signal(t - start)`` is the very float the signal
    made at ``start`` computes (``t - origin``)."""

    signal: Signal
    relative: bool = False

    def at(self, start: float) -> Signal:
        signal = self.signal
        if not self.relative or start == 0.0:
            return signal
        return shifted(signal, start)  # (a column of many times at once, issue 24)


@dataclass(frozen=True, slots=True)
class AnalogPlan:
    address: int
    signal: SignalPlan
    power: int | None = None


@dataclass(frozen=True, slots=True)
class PulsePlan:
    timer: bool
    address: int
    seed: int
    rate: float = 0.0
    burst_rate: float = 0.0
    burst: int = 1


@dataclass(frozen=True, slots=True)
class ThermometerPlan:
    pin: int
    rom: int
    signal: SignalPlan
    power: int | None = None


#: A 12 V supply (the world without a site file).
_SUPPLY = SignalPlan(constant(12.0))


@dataclass(frozen=True, slots=True)
class SimPlan:
    """The simulated hardware a ``[logger]`` table describes, checked; :meth:`build` it."""

    supply: SignalPlan = _SUPPLY
    supply_power: int = 1
    external_reference: float = INTERNAL_REFERENCE
    analog: tuple[AnalogPlan, ...] = ()
    pulses: tuple[PulsePlan, ...] = ()
    thermometers: tuple[ThermometerPlan, ...] = ()
    gsm: tuple[tuple[str, SignalPlan], ...] = ()

    def build(self, start: float) -> SimHardware:
        """The hardware of a simulation starting at host-clock time ``start``."""
        return SimHardware(
            supply=self.supply.at(start),
            supply_power=self.supply_power,
            external_reference=self.external_reference,
            analog=[Analog(a.address, a.signal.at(start), a.power) for a in self.analog],
            pulses=[
                PulseSource(p.timer, p.address, p.rate, p.burst_rate, p.burst, p.seed, start)
                for p in self.pulses
            ],
            thermometers=[
                Thermometer(t.pin, t.rom, t.signal.at(start), t.power) for t in self.thermometers
            ],
            gsm={key: signal.at(start) for key, signal in self.gsm},
        )


def plan_logger(logger: Table) -> SimPlan:
    """The plan of the ``[logger]`` table ``logger``; raises :class:`ConfigError`."""
    logger.keys(LOGGER_KEYS)
    rng = random.Random(logger.integer("seed", 0, lo=0, hi=2**63, what=f"an integer 0..{2**63}"))
    supply = _signal(logger, "supply") if "supply" in logger else _SUPPLY
    supply_power = logger.integer("supply_power", 1, lo=1, hi=7)
    reference = logger.number("external_reference", INTERNAL_REFERENCE, above=0, what="volts > 0")
    analog = _analog(logger.tables("analog", _ANALOG_KEYS))
    pulses = tuple(_pulses(entry, rng) for entry in logger.tables("pulses", _PULSE_KEYS))
    thermometers = _thermometers(logger.tables("ds18b20", _DS_KEYS), rng)
    gsm = logger.table("gsm", _GSM_KEYS)
    signals = tuple((key, _signal(gsm, key)) for key in _GSM_KEYS if key in gsm)
    return SimPlan(supply, supply_power, reference, analog, pulses, thermometers, signals)


def plan_site(site: Table) -> SimPlan:
    """The plan of a site file's ``[logger]`` table (the default world without one)."""
    logger = site.opt_table("logger")
    return plan_logger(logger) if logger is not None else SimPlan()


def _signal(table: Table, key: str) -> SignalPlan:
    """The signal table ``key`` of ``table`` (required)."""
    signal = table.table(key, required=True)
    return SignalPlan(read_signal(signal, 0.0), relative="origin" not in signal)


def _power(table: Table) -> int | None:
    return table.opt_integer("power", lo=1, hi=7)


def _analog(entries: list[Table]) -> tuple[AnalogPlan, ...]:
    analog: list[AnalogPlan] = []
    allowed = ", ".join(map(str, ANALOG_ADDRESSES))
    for entry in entries:
        what = f"an ADC input address ({allowed})"
        address = entry.integer("address", what=what)
        if address not in ANALOG_ADDRESSES:
            raise entry.fail("address", f"must be {what}, not {address}")
        if any(pin_of(a.address) == pin_of(address) for a in analog):
            raise entry.fail("address", "this input is already described")
        analog.append(AnalogPlan(address, _signal(entry, "signal"), _power(entry)))
    return tuple(analog)


def _pulses(entry: Table, rng: random.Random) -> PulsePlan:
    timer = entry.flag("timer", False)
    address = 0 if timer else entry.integer("address", lo=0, hi=36)
    seed = rng.randrange(2**32)
    if "rate" in entry and "poisson" in entry:
        raise entry.fail("poisson", "give either rate or poisson, not both")
    if "rate" in entry:
        rate = entry.number("rate", lo=0, what="pulses per second >= 0")
        return PulsePlan(timer, address, seed, rate=rate)
    if "poisson" not in entry:
        raise entry.fail(None, "needs rate = <Hz> or poisson = { rate = ..., burst = ... }")
    poisson = entry.table("poisson", _POISSON_KEYS)
    return PulsePlan(
        timer,
        address,
        poisson.integer("seed", seed, lo=0, hi=2**63, what=f"an integer 0..{2**63}"),
        burst_rate=poisson.number("rate", above=0, what="bursts per second > 0"),
        burst=poisson.integer("burst", 1, lo=1, hi=10**6),
    )


def _thermometers(entries: list[Table], rng: random.Random) -> tuple[ThermometerPlan, ...]:
    thermometers: list[ThermometerPlan] = []
    for entry in entries:
        pin = entry.integer("pin", lo=0, hi=7)
        if "rom" in entry:
            rom = int(entry.text("rom", pattern=r"(0x)?[0-9A-Fa-f]{16}", what=_HEX), 16)
            if not rom_valid(rom):
                raise entry.fail("rom", "needs family 0x28 in the lowest byte and a valid CRC-8")
        else:
            rom = rom_code(rng.randrange(2**48))
        if any(t.rom == rom for t in thermometers):
            raise entry.fail("rom", "two sensors with one ROM code")
        thermometers.append(ThermometerPlan(pin, rom, _signal(entry, "signal"), _power(entry)))
    return tuple(thermometers)


_HEX = "16 hexadecimal digits"


def load_logger_site(path: Path, start: float) -> SimHardware:
    """The simulated hardware of the site file at ``path`` (its ``[logger]`` table)."""
    return plan_site(load(path)).build(start)

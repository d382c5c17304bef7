"""The module's hardware as the ALA1 core sees it (DESIGN.md point 4, §6.4, §6.7, §12).

A backend implements :class:`Hardware`: the simulation (:mod:`sondalog.backends.sim.logger`)
and, on a Linux board, real inputs. The core cannot tell them apart. All times are host-clock
seconds (the physical world's time; the module clock is the core's own business).

Readings are *normalised*: the device calibration of §6.4.4 turns them into physical units
with the factory constants (an ADC reading is a fraction of the 2.5 V internal reference; a
DS18B20 reading is the temperature divided by 3276.8; the supply divider gives 1/11 of the
supply voltage as a fraction of the reference). ``None`` means "no valid value": nothing
connected, a sensor without power, a bus collision.
"""

from __future__ import annotations

from typing import Protocol

#: Ratio of the internal supply-voltage divider (sondalog decision, documented in decisions).
SUPPLY_DIVIDER = 11.0
#: DS18B20 normalisation constant: the factory ``device cal mult`` (§6.4.4.1).
DS18B20_SCALE = 3276.8
#: DS18B20 family code, the lowest byte of every ROM code (§6.4.3.1.1).
DS18B20_FAMILY = 0x28
#: A DS18B20 temperature conversion takes 750 ms (spec notes §7).
DS18B20_CONVERSION = 0.75
#: The MSP430's internal A/D reference, volts (§6.4.4.1).
INTERNAL_REFERENCE = 2.5
#: Full scale of the 12-bit A/D converter.
ADC_LEVELS = 4095
#: The MSP430ADC input addresses (§6.5.5); 32..36 are the pins of 16..20 (external reference).
ANALOG_ADDRESSES = (16, 17, 18, 19, 20, 24, 32, 33, 34, 35, 36)


class Hardware(Protocol):
    """Inputs and outputs of one ALA1 module."""

    def adc(self, device: int, address: int, t: float) -> float | None:
        """Normalised A/D reading (0..1 of the reference, 12-bit) of an MSP430ADC input."""
        ...

    def supply(self, t: float) -> float | None:
        """Normalised reading of the supply-voltage divider (valid while it is powered)."""
        ...

    def pulses(self, device: int, address: int, timer: bool, t0: float, t1: float) -> int:
        """Pulses counted in ``[t0, t1)`` on an MSP430TA (``timer``) or MSP430ADC input."""
        ...

    def ds18b20(self, pin: int, rom: int, t: float) -> tuple[int, float] | None:
        """(ROM code, normalised reading) of the DS18B20 on P6 bit ``pin``.

        ``rom`` 0 addresses the only sensor on the pin (several answering collide and give
        None); a ROM code whose lowest byte is 0 is a detection address (§6.4.3.1.1) and
        also addresses the only sensor; any other value selects that sensor.
        """
        ...

    def gsm(self, what: str, t: float) -> float | None:
        """GSM network readings: ``"signal"`` (channel type 12) or ``"credit"`` (type 11)."""
        ...

    def set_output(self, output: int, on: bool, t: float) -> None:
        """Output ``output`` (1..7) switched on or off at ``t`` (§6.7)."""
        ...

    def prepare(self, t: float) -> None:
        """The core will read inputs at host time ``t`` (its next sampling instant).

        A backend that needs time to acquire (a 750 ms DS18B20 conversion, a slow ADC) starts
        its conversions so that the values are held by then; the read methods above never
        block. Simulated hardware has nothing to prepare."""
        ...


class NoHardware:
    """A module with nothing connected: every input reads as absent, outputs go nowhere."""

    def adc(self, device: int, address: int, t: float) -> float | None:
        return None

    def supply(self, t: float) -> float | None:
        return None

    def pulses(self, device: int, address: int, timer: bool, t0: float, t1: float) -> int:
        return 0

    def ds18b20(self, pin: int, rom: int, t: float) -> tuple[int, float] | None:
        return None

    def gsm(self, what: str, t: float) -> float | None:
        return None

    def set_output(self, output: int, on: bool, t: float) -> None:
        return None

    def prepare(self, t: float) -> None:
        return None


def dallas_crc8(data: bytes) -> int:
    """Dallas/Maxim 1-Wire CRC-8 (polynomial x^8 + x^5 + x^4 + 1, reflected 0x8C)."""
    crc = 0
    for byte in data:
        for _ in range(8):
            mix = (crc ^ byte) & 1
            crc >>= 1
            if mix:
                crc ^= 0x8C
            byte >>= 1
    return crc


def rom_code(serial: int) -> int:
    """A valid DS18B20 ROM code for a 48-bit serial: family 0x28 low, CRC-8 high."""
    body = bytes([DS18B20_FAMILY]) + (serial & 0xFFFF_FFFF_FFFF).to_bytes(6, "little")
    return int.from_bytes(body + bytes([dallas_crc8(body)]), "little")


def rom_valid(code: int) -> bool:
    raw = code.to_bytes(8, "little")
    return raw[0] == DS18B20_FAMILY and dallas_crc8(raw[:7]) == raw[7]


def pin_of(address: int) -> int:
    """The physical input of an MSP430ADC address: external-reference addresses (32..36)
    name the same pins as 16..20 (§6.5.5)."""
    return address - 16 if address >= 32 else address


def normalise(volts: float, reference: float = INTERNAL_REFERENCE) -> float:
    """Volts on an input -> the 12-bit reading (fraction of ``reference``) that saturates at
    both ends (spec notes §7); NaN reads as 0."""
    fraction = volts / reference
    if fraction >= 1.0:
        return 1.0
    return round(fraction * ADC_LEVELS) / ADC_LEVELS if fraction > 0.0 else 0.0

"""Signal and credit readings for channel types 11 and 12 (§6.5.6.6-7, §6.11.7, gsm.md §6).

``com status sim credit code`` is ``<b>code<b>prefix<b>prefix2``: the first character is the
boundary, then the USSD code, then optionally the text after which the credit stands in the
network's answer, and an alternative text. Without a prefix the credit is the first number of
the answer. The readings are kept in :class:`GsmReadings`, which the measurer sees through
:class:`ModemHardware`, a wrapper of the module's :class:`~sondalog.ala1.hardware.Hardware`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from sondalog.ala1.hardware import Hardware

_NUMBER = re.compile(r"-?\d+(?:[.,]\d+)?")


@dataclass(frozen=True)
class CreditCode:
    code: str
    prefixes: tuple[str, ...] = ()


def parse_credit_code(text: str) -> CreditCode | None:
    """The parameter's parts, or None when it is empty or holds no code."""
    text = text.strip()
    if len(text) < 2:
        return None
    boundary, rest = text[0], text[1:]
    parts = rest.split(boundary)
    code = parts[0]
    if not code:
        return None
    return CreditCode(code, tuple(p for p in parts[1:3] if p))


def credit_from_answer(answer: str, code: CreditCode) -> float | None:
    """The credit in the network's USSD answer (the number after a prefix, or the first)."""
    places = [answer.find(p) + len(p) for p in code.prefixes if p in answer]
    if code.prefixes and not places:
        return None
    start = places[0] if places else 0
    found = _NUMBER.search(answer, start)
    return None if found is None else float(found.group().replace(",", "."))


def rssi_from_csq(line: str) -> int | None:
    """``+CSQ: <rssi>,<ber>`` -> rssi 0..31; 99 (unknown) is no value."""
    try:
        rssi = int(line.split(":", 1)[1].split(",")[0])
    except (IndexError, ValueError):
        return None
    return rssi if 0 <= rssi <= 31 else None


@dataclass
class GsmReadings:
    """The last signal and credit read at a GSM communication (None: none valid yet)."""

    signal: int | None = None
    credit: float | None = None


class ModemHardware:
    """The module's hardware with its GSM readings taken from the modem driver."""

    def __init__(self, inner: Hardware, readings: GsmReadings) -> None:
        self.inner = inner
        self.readings = readings

    def adc(self, device: int, address: int, t: float) -> float | None:
        return self.inner.adc(device, address, t)

    def supply(self, t: float) -> float | None:
        return self.inner.supply(t)

    def pulses(self, device: int, address: int, timer: bool, t0: float, t1: float) -> int:
        return self.inner.pulses(device, address, timer, t0, t1)

    def ds18b20(self, pin: int, rom: int, t: float) -> tuple[int, float] | None:
        return self.inner.ds18b20(pin, rom, t)

    def gsm(self, what: str, t: float) -> float | None:
        if what == "signal":
            return None if self.readings.signal is None else float(self.readings.signal)
        if what == "credit":
            return self.readings.credit
        return None

    def set_output(self, output: int, on: bool, t: float) -> None:
        self.inner.set_output(output, on, t)

    def prepare(self, t: float) -> None:
        self.inner.prepare(t)

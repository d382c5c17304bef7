"""The value grammar of an ALA1 setting as the host checks it before writing (§4.3, §6).

The host keeps its own copy of the logger's value grammar (docs/decisions.md "Station files:
the host's own schema"): a value in a station file is checked here, turned into its canonical
text (what the logger stores) and into the text a ``write`` command carries.
``tests/station/test_schema_matches_tree.py`` walks the logger's parameter tree and proves
that every configurable leaf has a setting here whose grammar accepts exactly the values the
logger reads back, and nothing the logger would refuse.

The host accepts the canonical forms only (a date of all 14 digits, a period of all six),
a subset of what the logger's parser takes: a file always says the whole value.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from decimal import ROUND_HALF_UP, Context, Decimal, InvalidOperation

from sondalog.client.ala1_codec import MAX_LINE

#: §6.11.2: the baud rates of the serial interface.
BAUD_RATES = (300, 600, 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400)
#: Total memory of the module (spec notes §5).
TOTAL_MEMORY = 1048576
#: Written numbers stay below this magnitude (docs/decisions.md "Number limits").
NUMBER_LIMIT = Decimal(10) ** 15
#: String boundaries tried in order (§4.2.3): the first not in the value is used.
BOUNDARIES = "/|*#!~^@%+=;:"
_NUMBER = re.compile(r"-?[0-9]+(\.[0-9]+)?")
_WIDE = Context(prec=60)


@dataclass(frozen=True)
class Limits:
    """Counts that differ between protocol versions (spec notes §5)."""

    channels: int
    commands: int
    addresses: int
    messages: int
    addresses_per_message: int
    channel_address_max: int
    devices: int = 8
    outputs: int = 7


LIMITS: dict[str, Limits] = {
    "1.16": Limits(8, 4, 8, 2, 1, 0xFFFF),
    "2.10": Limits(12, 40, 40, 40, 10, 0xFFFF_FFFF_FFFF_FFFF),
}

Bound = int | Callable[[Limits], int]


def _bound(value: Bound, limits: Limits) -> int:
    return value(limits) if callable(value) else value


class Grammar:
    """A value type: ``check`` gives the canonical text or raises ``ValueError``."""

    kind = "value"
    #: In a TOML file the value is an integer (else a string).
    toml_int = False

    def check(self, text: str, limits: Limits) -> str:
        raise NotImplementedError

    def written(self, canonical: str) -> str:
        """The value as a ``write`` command carries it (after the keywords)."""
        return " " + canonical


@dataclass(frozen=True)
class Text(Grammar):
    """An unknown-length string (§4.2.3): printable ASCII, at most ``max_len`` characters."""

    max_len: int | None = None
    kind = "string"

    def check(self, text: str, limits: Limits) -> str:
        bad = next((c for c in text if not 32 <= ord(c) < 127), None)
        if bad is not None:
            raise ValueError(f"{bad!r}: the logger's line carries printable ASCII only (§6.11)")
        if self.max_len is not None and len(text) > self.max_len:
            raise ValueError(f"at most {self.max_len} characters, not {len(text)}")
        if all(b in text for b in BOUNDARIES):
            raise ValueError("the string holds every boundary character sondalog can use")
        return text

    def written(self, canonical: str) -> str:
        boundary = next(b for b in BOUNDARIES if b not in canonical)
        return f"{boundary}{canonical}{boundary}"


@dataclass(frozen=True)
class RestOfLine(Grammar):
    """The rest of the line verbatim (§6.11.7): its first character is its own boundary."""

    kind = "rest of line"

    def check(self, text: str, limits: Limits) -> str:
        if not text.strip():
            raise ValueError("a value starting with its boundary character: /*101#/Kc/")
        return Text().check(text, limits)

    def written(self, canonical: str) -> str:
        return canonical


@dataclass(frozen=True)
class Integer(Grammar):
    """An integer within ``lo..hi`` (§4.3.4)."""

    lo: int = 0
    hi: Bound = 65535
    kind = "integer"
    toml_int = True

    def check(self, text: str, limits: Limits) -> str:
        if not text.isdigit() or not text.isascii():
            raise ValueError(f"an integer {self.lo}..{_bound(self.hi, limits)}, not {text!r}")
        value = int(text)
        if not self.lo <= value <= _bound(self.hi, limits):
            raise ValueError(f"{value} outside {self.lo}..{_bound(self.hi, limits)}")
        return str(value)


@dataclass(frozen=True)
class OneOf(Grammar):
    """An integer from a set (§6.11.2 baud rates, §6.5.6 channel types, §6.17.2)."""

    options: tuple[int, ...] = ()
    kind = "integer"
    toml_int = True

    def check(self, text: str, limits: Limits) -> str:
        if not text.isdigit() or int(text) not in self.options:
            raise ValueError(f"one of {', '.join(map(str, self.options))}, not {text!r}")
        return str(int(text))


@dataclass(frozen=True)
class MemorySize(Grammar):
    """A memory area: a multiple of 256 within the memory (§6.15)."""

    minimum: int = 0
    kind = "integer"
    toml_int = True

    def check(self, text: str, limits: Limits) -> str:
        value = Integer(self.minimum, TOTAL_MEMORY).check(text, limits)
        if int(value) % 256:
            raise ValueError(f"a memory size is a multiple of 256, not {value}")
        return value


@dataclass(frozen=True)
class ChannelAddress(Grammar):
    """A channel address (§6.5.5): 16-bit in 1.16, 64-bit in 2.10."""

    kind = "integer"
    toml_int = True

    def check(self, text: str, limits: Limits) -> str:
        return Integer(0, limits.channel_address_max).check(text, limits)


@dataclass(frozen=True)
class Choice(Grammar):
    """An enumerated keyword (spec notes §1), read back in upper case; ``with_arg`` options
    take a number (``RINGVOICE,2``, §6.10.2.3)."""

    options: tuple[str, ...] = ()
    with_arg: tuple[tuple[str, Bound], ...] = ()
    kind = "keyword"

    def check(self, text: str, limits: Limits) -> str:
        name, _, arg = text.replace(" ", ",", 1).partition(",")
        name = name.upper()
        args = dict(self.with_arg)
        if name not in self.options:
            raise ValueError(f"one of {', '.join(self.options)}, not {text!r}")
        if name in args:
            return f"{name},{Integer(1, args[name]).check(arg.strip(), limits)}"
        if arg:
            raise ValueError(f"{name} takes no number")
        return name

    def written(self, canonical: str) -> str:
        return " " + canonical.replace(",", " ").lower()


@dataclass(frozen=True)
class Number(Grammar):
    """A decimal number (§4.3.4), read back in a number format (§4.3.5)."""

    lo: Decimal | None = None
    special: tuple[Decimal, ...] = ()
    kind = "number"

    def check(self, text: str, limits: Limits) -> str:
        if not _NUMBER.fullmatch(text):
            raise ValueError(f"a number like -0.8 or 13.8, not {text!r}")
        value = Decimal(text)
        if abs(value) >= NUMBER_LIMIT:
            raise ValueError(f"{text}: numbers stay below 10^15")
        if value not in self.special and self.lo is not None and value < self.lo:
            also = "".join(f" or {s}" for s in self.special)
            raise ValueError(f"{text}: at least {self.lo}{also}")
        return format(value, "f")


@dataclass(frozen=True)
class Format(Grammar):
    """A number format ``w.p`` (§4.3.5)."""

    kind = "format"

    def check(self, text: str, limits: Limits) -> str:
        if not re.fullmatch(r"[0-9]\.[0-9]", text):
            raise ValueError(f"a number format w.p (three characters, 0.1), not {text!r}")
        return text


@dataclass(frozen=True)
class Date(Grammar):
    """A date ``YYYYMMDDhhmmss`` (§4.3.2), all 14 digits."""

    kind = "date"

    def check(self, text: str, limits: Limits) -> str:
        if len(text) != 14 or not text.isdigit() or not text.isascii():
            raise ValueError(f"a date YYYYMMDDhhmmss (14 digits), not {text!r}")
        try:
            datetime.strptime(text, "%Y%m%d%H%M%S")
        except ValueError:
            raise ValueError(f"{text} is not a date of the calendar") from None
        if text[:4] == "0000":
            raise ValueError(f"{text} is not a date of the calendar")
        return text


@dataclass(frozen=True)
class Period(Grammar):
    """A period ``hhmmss`` <= 96 h or ``99DDHH`` <= 90 days (§4.3.3); ``999901`` (one
    month) only for messages."""

    month: bool = False
    kind = "period"

    def check(self, text: str, limits: Limits) -> str:
        if len(text) != 6 or not text.isdigit() or not text.isascii():
            raise ValueError(f"a period hhmmss (six digits), not {text!r}")
        hh, mm, ss = int(text[0:2]), int(text[2:4]), int(text[4:6])
        if text == "999901":
            if not self.month:
                raise ValueError("the one-month period 999901 is only for messages")
        elif hh == 99:
            if mm * 24 + ss > 90 * 24 or ss > 23:
                raise ValueError(f"{text}: a 99DDHH period is at most 90 days, hours below 24")
        elif mm > 59 or ss > 59 or hh * 3600 + mm * 60 + ss > 96 * 3600:
            raise ValueError(f"{text}: at most 96 hours, minutes and seconds below 60")
        return text


@dataclass(frozen=True)
class IntList(Grammar):
    """Address numbers separated by commas (§6.14.2.1)."""

    kind = "integer list"

    def check(self, text: str, limits: Limits) -> str:
        items = text.replace(" ", "").split(",")
        if len(items) > limits.addresses_per_message:
            raise ValueError(f"at most {limits.addresses_per_message} address numbers")
        return ",".join(Integer(1, limits.addresses).check(i, limits) for i in items)


@dataclass(frozen=True)
class OutputValue(Grammar):
    """An output's value (§6.7.3): 0, 1, or NO (released to automatic switching)."""

    kind = "0 | 1 | NO"

    def check(self, text: str, limits: Limits) -> str:
        if text.upper() not in ("0", "1", "NO"):
            raise ValueError(f"0, 1 or NO, not {text!r}")
        return text.upper()


def render_number(canonical: str, fmt: str) -> str:
    """``canonical`` in format ``w.p`` as the logger reads it back, without the padding
    (§4.3.5: half away from zero)."""
    decimals = int(fmt[2])
    try:
        rounded = Decimal(canonical).quantize(
            Decimal(1).scaleb(-decimals), rounding=ROUND_HALF_UP, context=_WIDE
        )
    except InvalidOperation:
        return canonical
    if rounded == 0:
        rounded = abs(rounded)
    return f"{rounded:.{decimals}f}"


def fits_line(command: str) -> str | None:
    """Why ``command`` cannot be sent as one line (§3.4.1), or None."""
    if len(command) > MAX_LINE:
        return f"the write is {len(command)} characters; a command line holds {MAX_LINE}"
    return None

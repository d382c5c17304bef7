"""Record rows as the logger sends them (§6.6, §6.8.1, spec notes §6).

Pure functions, no I/O. A row is ``YYYYMMDDhhmmss.c,t,f1,...,fn``: ``c`` counts the rows
written in the same second (``0``-``9`` then ``A``-``Z``), ``t`` is the row type (1 scheduled
samples, 2 ``write channel value``, 3..9 text) and ``f1..fn`` the channel fields, empty when a
channel has no value in that row. A text row is ``stamp,t,text`` (the text may hold commas).
``write text 1/abc/`` stores a text row of type 1, so a row of type 1 or 2 whose fields are
not all numbers (or empty) is a text row too.

:mod:`sondalog.collect.readings` turns rows into the collector's readings.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from datetime import datetime
from zoneinfo import ZoneInfo

COUNTERS = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ"
_KEY = re.compile(r"(\d{14})\.([0-9A-Z])")
#: Fields that are each a number or empty, comma separated (one match for a whole row).
_NUMBERS = re.compile(r"(?:-?\d+(?:\.\d+)?)?(?:,(?:-?\d+(?:\.\d+)?)?)*")
_UNIT = re.compile(r"^(.*?)\s*\[([^\[\]]*)\]\s*$")
UTC = ZoneInfo("UTC")


class RowError(ValueError):
    """A line that is not a record row."""


@dataclass(frozen=True, slots=True)
class Row:
    """One record row."""

    key: str
    """The record point ``YYYYMMDDhhmmss.c`` (what ``read record N from date/KEY/`` takes)."""
    time: datetime
    counter: int
    type: int
    values: tuple[float | None, ...] = ()
    text: str | None = None

    @property
    def is_text(self) -> bool:
        return self.text is not None


@dataclass(frozen=True, slots=True)
class Channel:
    """A channel's name and unit as the logger reports them (§6.5.3)."""

    name: str
    unit: str | None = None


def parse_key(key: str) -> tuple[datetime, int]:
    """``20070301120000.3`` -> (2007-03-01 12:00:00, 3); raises :class:`RowError`."""
    match = _KEY.fullmatch(key)
    if match is None:
        raise RowError(f"not a record point: {key!r}")
    try:
        time = stamp(match.group(1))
    except ValueError:
        raise RowError(f"impossible date in {key!r}") from None
    return time, COUNTERS.index(match.group(2))


def stamp(text: str) -> datetime:
    """``20070301120000`` -> 2007-03-01 12:00:00, as ``strptime(text, "%Y%m%d%H%M%S")``
    reads it (ValueError likewise); fourteen ASCII digits are sliced, without ``strptime``'s
    cost (a row's stamp is read for every row downloaded)."""
    if len(text) == 14 and text.isascii() and text.isdigit():
        return datetime(
            int(text[:4]),
            int(text[4:6]),
            int(text[6:8]),
            int(text[8:10]),
            int(text[10:12]),
            int(text[12:]),
        )
    return datetime.strptime(text, "%Y%m%d%H%M%S")


def make_key(time: datetime, counter: int) -> str:
    """The inverse of :func:`parse_key`."""
    return f"{time:%Y%m%d%H%M%S}.{COUNTERS[counter]}"


def parse_row(line: str) -> Row:
    """One row as the logger sends it (without CR LF); raises :class:`RowError`."""
    key, sep, rest = line.partition(",")
    type_text, sep2, body = rest.partition(",")
    if not sep or not type_text.isdigit() or len(type_text) != 1 or type_text == "0":
        raise RowError(f"not a record row: {line[:80]!r}")
    time, counter = parse_key(key)
    row_type = int(type_text)
    if not sep2:
        if row_type >= 3:
            return Row(key, time, counter, row_type, text="")
        return Row(key, time, counter, row_type)
    if row_type <= 2 and _NUMBERS.fullmatch(body):  # each field a number or empty
        values = tuple([float(f) if f else None for f in body.split(",")])
        return Row(key, time, counter, row_type, values)
    return Row(key, time, counter, row_type, text=body)


@functools.lru_cache(maxsize=4096)
def split_name(name: str) -> Channel:
    """``Supply[V]`` -> Channel("Supply", "V") (the factory name, §11); no brackets: no unit.
    The same name gives the same (frozen) channel: ten thousand loggers' ``Supply[V]`` are
    one object."""
    match = _UNIT.match(name)
    if match is None or not match.group(1):
        return Channel(name)
    return Channel(match.group(1), match.group(2) or None)


def to_utc(local: datetime, zone: ZoneInfo) -> datetime:
    """A stamp of the logger's clock in ``zone`` -> aware UTC (ambiguous times: the first)."""
    return local.replace(tzinfo=zone).astimezone(UTC)

"""The small value syntaxes of ``[[alarm]]`` and ``[[notify]]``: durations, rates, quiet
windows. Each parser takes the string and raises ``ValueError`` with a message the config
reader (``Table.convert``) turns into ``FILE:LINE: field: message``."""

from __future__ import annotations

import re
from datetime import time

from sondalog.config import Table

from .rules import Quiet, Rate

_UNITS = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0}
_PART = re.compile(r"(\d+(?:\.\d+)?)\s*([smhd])")


def parse_duration(text: str) -> float:
    """``"90s"``, ``"15m"``, ``"1h30m"``, ``"2d"`` -> seconds (> 0)."""
    spaced = text.strip()
    parts = _PART.findall(spaced)
    if not parts or _PART.sub("", spaced).strip():
        raise ValueError(f'must be seconds or a duration like "90s", "15m", "1h30m", not {text!r}')
    seconds = sum(float(n) * _UNITS[u] for n, u in parts)
    if seconds <= 0:
        raise ValueError(f"must be a duration > 0, not {text!r}")
    return seconds


def duration(table: Table, key: str, default: float | None = None) -> float | None:
    """``key`` as seconds: a number (> 0) or a duration string; ``default`` if absent."""
    if key not in table:
        return default
    if table.is_text(key):
        return table.convert(key, parse_duration)
    return table.number(key, above=0, what='seconds > 0 or a duration like "15m"')


def parse_rate(text: str) -> Rate:
    """``"5/h"``, ``"10/30m"``, ``"3/600s"`` -> at most N messages per window."""
    count, sep, per = text.partition("/")
    if not sep or not count.strip().isdigit() or int(count) < 1:
        raise ValueError(f'must be "COUNT/DURATION" like "5/h" or "10/30m", not {text!r}')
    per = per.strip()
    window = parse_duration(f"1{per}" if per in _UNITS else per)
    return Rate(int(count), window)


def parse_quiet(text: str) -> Quiet:
    """``"22:00-06:00"`` -> a daily window of local time (may span midnight)."""
    match = re.fullmatch(r"\s*(\d{1,2}):(\d\d)\s*-\s*(\d{1,2}):(\d\d)\s*", text)
    if match is None:
        raise ValueError(f'must be "HH:MM-HH:MM" like "22:00-06:00", not {text!r}')
    h1, m1, h2, m2 = (int(g) for g in match.groups())
    if h1 > 23 or h2 > 23 or m1 > 59 or m2 > 59:
        raise ValueError(f"has no such time of day: {text!r}")
    start, end = time(h1, m1), time(h2, m2)
    if start == end:
        raise ValueError(f"is an empty window: {text!r}")
    return Quiet(start, end)


def one_or_many(table: Table, key: str) -> list[str]:
    """A string or an array of strings (``to = "a@b"`` or ``to = ["a@b", "c@d"]``)."""
    if table.is_text(key):
        return [table.text(key)]
    return table.texts(key, empty=False)


#: An http:// or https:// URL (sms via the network's API, webhooks).
HTTP_URL = r"https?://\S+"


def many_matching(table: Table, key: str, pattern: str, what: str) -> tuple[str, ...]:
    """:func:`one_or_many`, each item matching ``pattern`` (``what`` names it: "must be
    {what}, not ...")."""
    items = one_or_many(table, key)
    for item in items:
        if re.fullmatch(pattern, item) is None:
            raise table.fail(key, f"must be {what}, not {item!r}")
    return tuple(items)

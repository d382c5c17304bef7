"""The module clock as seconds (§6.2: ``date``): conversions and the calendar's ends.

The module clock is the host clock plus a stored offset (a battery-backed clock); sampling
works in whole module seconds since 1970. At either end of the calendar the clock holds
(docs/decisions.md "The end of the calendar").
"""

from __future__ import annotations

import math
from datetime import datetime, timedelta

_EPOCH = datetime(1970, 1, 1)
#: The clock of a new virtual module (§11 factory value of ``date``).
FACTORY_DATE = datetime(2000, 1, 1)


def to_seconds(moment: datetime) -> float:
    return (moment - _EPOCH).total_seconds()


#: The calendar's ends (§4.3.2: four-digit years). The module clock holds at either end
#: instead of overflowing (docs/decisions.md "The end of the calendar").
CLOCK_MIN = to_seconds(datetime(1, 1, 1))
CLOCK_MAX = to_seconds(datetime(9999, 12, 31, 23, 59, 59))


def from_seconds(seconds: float) -> datetime:
    """The date of module ``seconds``, held within the calendar (never an overflow)."""
    return _EPOCH + timedelta(seconds=_held(seconds))


def _held(seconds: float) -> int:
    """The whole module second of ``seconds``, held within the calendar."""
    return math.floor(min(max(seconds, CLOCK_MIN), CLOCK_MAX))


def stamp(seconds: float) -> str:
    """The record's ``YYYYMMDDhhmmss`` of module ``seconds`` (§6.6.5: a row's time), as
    :func:`from_seconds` and ``tokens.format_stamp`` give it: the date of each day worked
    out once, ``hhmm`` and ``ss`` looked up (a simulated year writes a row every minute,
    issue 24)."""
    held = seconds if type(seconds) is int and _LOW <= seconds <= _HIGH else _held(seconds)
    day, rest = divmod(held, 86400)
    date = _DATES.get(day)
    if date is None:
        if len(_DATES) >= 64:
            _DATES.clear()
        moment = _EPOCH + timedelta(days=day)
        date = _DATES[day] = f"{moment.year:04d}{moment.month:02d}{moment.day:02d}"
    minute, secs = divmod(rest, 60)
    return date + _HHMM[minute] + _SS[secs]


def stamps(seconds: list[int]) -> list[str]:
    """:func:`stamp` of each of ``seconds`` (ascending whole seconds: a stretch of sampling
    instants, issue 24), the date looked up once a day instead of once a row."""
    out: list[str] = []
    hhmm, ss = _HHMM, _SS
    date, begin, end = "", 0, 0  # the day stamped last: its date, its seconds [begin, end)
    for t in seconds:
        if type(t) is not int or not begin <= t < end:
            if type(t) is not int or not _LOW <= t <= _HIGH:
                out.append(stamp(t))  # (held at the calendar's ends: one by one)
                begin = end = 0
                continue
            begin = t - t % 86400  # (the calendar's ends are midnights: its whole days)
            end = begin + 86400
            date = stamp(begin)[:8]
        rest = t % 86400
        out.append(date + hhmm[rest // 60] + ss[rest % 60])
    return out


_LOW, _HIGH = math.ceil(CLOCK_MIN), math.floor(CLOCK_MAX)
#: Dates of the days stamped lately, by day since 1970.
_DATES: dict[int, str] = {}
_HHMM = [f"{h:02d}{m:02d}" for h in range(24) for m in range(60)]
_SS = [f"{s:02d}" for s in range(60)]

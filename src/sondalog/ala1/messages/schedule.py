"""When a periodic message is due (§6.14.4 period, §6.14.5 start).

Times are module seconds (the module clock as seconds since 1970). A message with period P
and start S is due at S + k*P; a start in the past moves forward by whole periods, as a
channel's sampling does (§6.5.14). The one-month period (``999901``, §4.3.3) keeps the start's
day of the month and time of day; a month that has no such day uses its last day (§6.14.4:
a message started on the 31st goes on 28 or 29 February, 30 April, then 31 May again).
"""

from __future__ import annotations

import calendar
import math
from datetime import datetime

from sondalog.ala1.moduleclock import CLOCK_MAX, from_seconds, to_seconds
from sondalog.ala1.tokens import MONTH_PERIOD, period_seconds


def add_months(start: datetime, months: int) -> datetime:
    """``start`` moved by ``months`` calendar months, the day clamped to the month's end."""
    index = start.year * 12 + (start.month - 1) + months
    year, month = divmod(index, 12)
    last = calendar.monthrange(year, month + 1)[1]
    return start.replace(year=year, month=month + 1, day=min(start.day, last))


def next_due(period: str, start: float, now: float) -> float | None:
    """The first instant at or after module second ``now`` when the message is due; None
    when the period is ``000000`` (off) or the instant lies past the end of the calendar."""
    if period == MONTH_PERIOD:
        return _next_month(from_seconds(start), now)
    seconds = period_seconds(period)
    if not seconds:
        return None
    if now <= start:
        due = start
    else:
        due = start + math.ceil((now - start) / seconds) * seconds
    return due if due <= CLOCK_MAX else None


def _next_month(start: datetime, now: float) -> float | None:
    begin = to_seconds(start)
    if now <= begin:
        return begin
    moment = from_seconds(now)
    months = max((moment.year - start.year) * 12 + moment.month - start.month - 1, 0)
    while True:
        if start.year * 12 + start.month + months > 9999 * 12 + 12:
            return None
        due = to_seconds(add_months(start, months))
        if due >= now:
            return due
        months += 1

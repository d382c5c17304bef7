"""Times as the store keeps them, and as the dashboard's parameters give them.

The store's ``time`` column is the logger's own clock, ``YYYY-MM-DDTHH:MM:SS`` without a
zone (see :mod:`sondalog.collect.schema`). The dashboard never converts it to another zone:
it plots it on a UTC axis so that the figures shown are the logger's own (what the logger's
``time`` command and its record say, §6.8). Pure functions, no clock.
"""

from __future__ import annotations

import calendar
from datetime import UTC, datetime, timedelta

#: The store's time format.
STORE_FORMAT = "%Y-%m-%dT%H:%M:%S"


class BadParameter(ValueError):
    """A request parameter that cannot be used; the message says which and why."""


def parse_time(name: str, text: str) -> str:
    """A parameter ``name`` given as ``YYYY-MM-DD[THH:MM[:SS]]`` -> the store's form.

    A space may stand for the ``T``; fractions of a second are dropped. A zone is refused:
    times are the logger's own clock.
    """
    raw = text.strip()
    try:
        when = datetime.fromisoformat(raw)
    except ValueError:
        raise BadParameter(
            f"{name}: expected a time like 2026-03-01T12:00:00 (logger's clock), got {text!r}"
        ) from None
    if when.tzinfo is not None:
        raise BadParameter(f"{name}: give the logger's own clock time without a zone, got {text!r}")
    return when.strftime(STORE_FORMAT)


def to_epoch(stamp: str) -> int:
    """A store time -> seconds since 1970 on the logger's clock read as UTC (the plot's x)."""
    return calendar.timegm(
        (
            int(stamp[0:4]),
            int(stamp[5:7]),
            int(stamp[8:10]),
            int(stamp[11:13]),
            int(stamp[14:16]),
            int(stamp[17:19]),
            0,
            0,
            0,
        )
    )


def from_epoch(seconds: float) -> str:
    """The inverse of :func:`to_epoch` (whole seconds)."""
    return datetime.fromtimestamp(int(seconds), UTC).strftime(STORE_FORMAT)


def shift(stamp: str, seconds: float) -> str:
    """A store time moved by ``seconds``."""
    return (datetime.strptime(stamp, STORE_FORMAT) + timedelta(seconds=seconds)).strftime(
        STORE_FORMAT
    )

"""The alarms of ``make demo`` (issue 21): a flood and a lost coverage its world makes, and
who is told.

The water level of ``CABLE-01`` (channel 2, ``Level``) is :func:`level_csv`: a river
wandering between :data:`BASE_LOW` and :data:`BASE_HIGH` through the whole history, then a
flood wave that starts :data:`FLOOD_START` module seconds after the history ends (the demo's
start: the history and the live signals share their origin), passes :data:`LIMIT` about
half an hour later, and falls under :data:`CLEAR` some three hours after that. At the demo's
speed (a module hour a real minute) the alarm is raised within the first two minutes and
cleared within the first five; the history never crossed, so the first download raises
nothing. The file loops every :data:`PERIOD`: a flood a month.

The GSM logger ``GSM-03`` e-mails its rows every module hour (:data:`MESSAGE_PERIOD`). Its
modem loses coverage :data:`COVERAGE_START` module seconds after the demo's start (at the
soonest :data:`FIRST_MAIL` real seconds after, when its first e-mail is in) for
:data:`COVERAGE_LOST` (a ``[[gsm.outage]]`` of the demo's network, in its real time:
:func:`coverage_outage`):
no e-mail comes, the mailbox answers empty, and the ``no_contact`` rule :data:`SILENT_RULE`
on its mailbox source raises after two message periods (:func:`silent_after`: seconds of
the collector's clock, which is real time); when the modem is back its next e-mail clears
it. At the demo's speed it is raised within the first four minutes and cleared within ten.

:func:`alarm_toml` is the collector's ``[[notify]]`` and ``[[alarm]]`` tables: e-mail to
:data:`OPS_MAIL` through the demo's mail hub (read it over POP3), SMS through the demo's GSM
network's HTTP API from :data:`ALARM_PHONE` (the collector's own SIM) to the user's phone.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

#: The account the alarm e-mails go to (its password ``secret``, as the others).
OPS_MAIL = "ops@example.net"
#: The network's phone the collector sends its SMS from.
ALARM_PHONE = "+420700000009"
#: Module days the level file covers before it loops.
PERIOD_DAYS = 30
PERIOD = PERIOD_DAYS * 86400.0
#: Seconds between the file's points (interpolated between).
POINT = 1800.0
BASE_LOW, BASE_HIGH = 0.8, 1.3
#: The flood: starts rising this long after the history's end, peaks PEAK for an hour.
FLOOD_START, RISE, HOLD, FALL, PEAK = 3600.0, 3600.0, 3600.0, 7200.0, 1.9
#: The threshold rule: raised above LIMIT (2 readings), cleared at or below CLEAR.
LIMIT, CLEAR = 1.6, 1.4
#: The level channel (``CABLE-01`` channel 2) and the rule's name.
LEVEL_LOGGER, LEVEL_CHANNEL, RULE = "CABLE-01", 2, "river flood"
#: The level file's name beside the site file.
LEVEL_FILE = "level.csv"
#: The GSM logger's message period (module seconds; ``write message 1 period 010000``).
MESSAGE_PERIOD = 3600.0
#: Its modem loses coverage this long after the demo's start, for this long (module time).
COVERAGE_START, COVERAGE_LOST = 5400.0, 8 * 3600.0
#: Real seconds the GSM logger's first e-mail (its whole history) may take: the coverage is
#: lost after it at the soonest.
FIRST_MAIL = 30.0
#: The no_contact rule on the GSM logger's mailbox source, and that source's name.
SILENT_RULE, MAILBOX_SOURCE = "gsm logger silent", "gsm-mail"
#: Real seconds the collector may wait beyond two message periods for an e-mail to be
#: sent, delivered and read from the mailbox (its poll interval is 5 s).
SILENT_SLACK = 15.0


def silent_after(speed: float) -> float:
    """The no_contact rule's ``after`` (real seconds) with module time ``speed`` times
    faster: two of the GSM logger's message periods and some slack."""
    return round(2 * MESSAGE_PERIOD / speed + SILENT_SLACK, 1)


def coverage_outage(now: float, speed: float) -> tuple[float, float]:
    """The GSM logger's modem's outage for a demo that writes its network at ``now`` with
    module time ``speed`` times faster: seconds since the epoch of the network's clock, which
    is real time (a network is lines: ``sondalog serve`` keeps it at 1x under ``--speed``)."""
    start = now + max(COVERAGE_START / speed, FIRST_MAIL)
    return start, start + COVERAGE_LOST / speed


def _flood(t: float, history: float, base: float) -> float | None:
    """The flood's level at ``t`` (seconds after the origin), None outside the wave."""
    x = t - history - FLOOD_START
    if x <= 0 or x >= RISE + HOLD + FALL:
        return None
    if x < RISE:
        return base + (PEAK - base) * x / RISE
    if x < RISE + HOLD:
        return PEAK
    return PEAK - (PEAK - base) * (x - RISE - HOLD) / FALL


def level_points(history_days: float) -> list[tuple[float, float]]:
    """``(seconds after the origin, level)`` every :data:`POINT` for :data:`PERIOD`: a
    seeded random walk between the bounds, and the flood after ``history_days``."""
    rng = random.Random(3)
    history = history_days * 86400.0
    level, points = 1.1, []
    start = history + FLOOD_START
    base = level
    for i in range(int(PERIOD / POINT) + 1):
        t = i * POINT
        level = min(BASE_HIGH, max(BASE_LOW, level + rng.gauss(0.0, 0.02)))
        if t <= start:
            base = level  # the wave rises from the level it finds, and falls back to it
        flood = _flood(t, history, base)
        points.append((t, round(level if flood is None else max(flood, level), 4)))
    return points


def level_csv(history_days: float) -> str:
    """:func:`level_points` as the ``csv`` signal model reads them (``time,value``)."""
    rows = [f"{t:g},{v:g}" for t, v in level_points(history_days)]
    return "time,value\n" + "\n".join(rows) + "\n"


@dataclass(frozen=True)
class AlarmWorld:
    """Where the demo's alarms notify: the mail hub's SMTP and the GSM network's API."""

    smtp: tuple[str, int]
    gsm_api: str  # http://HOST:PORT
    phone: str  # the user's phone the SMS go to
    speed: float = 60.0  # module seconds per real second


def alarm_toml(world: AlarmWorld) -> str:
    """The collector's ``[[notify]]`` and ``[[alarm]]`` tables (docs/alarms.md)."""
    host, port = world.smtp
    after = silent_after(world.speed)
    return f"""# Alarms (docs/alarms.md): the river floods an hour after the start (module time)
# and GSM-03 loses coverage for a few hours half an hour later
[[notify]]
name = "ops-mail"
kind = "email"
smtp = "{host}:{port}"
from = "{OPS_MAIL}"
to = ["{OPS_MAIL}"]
user = "{OPS_MAIL}"
password = "secret"

[[notify]]
name = "oncall-sms"
kind = "sms"
via = "network"
url = "{world.gsm_api}"
from = "{ALARM_PHONE}"
number = "{world.phone}"
rate = "10/h"

[[alarm]]
name = "{RULE}"
kind = "threshold"
logger = "{LEVEL_LOGGER}"
channel = {LEVEL_CHANNEL}                     # Level[V]
above = {LIMIT}
clear = {CLEAR}
for = 2
notify = ["ops-mail", "oncall-sms"]

[[alarm]]
name = "logger silent"
kind = "no_contact"
source = "[!g]*"
after = "2m"
notify = ["ops-mail"]

[[alarm]]
name = "{SILENT_RULE}"
kind = "no_contact"
source = "{MAILBOX_SOURCE}"
after = {after:g}                      # seconds: 2 of its message periods at this speed
notify = ["ops-mail", "oncall-sms"]"""

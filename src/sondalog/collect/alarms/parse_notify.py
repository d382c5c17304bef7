"""``[[notify]]`` tables of the collector's file: where alarms are told (issue 21).

::

    [[notify]]
    name = "ops-mail"
    kind = "email"                       # email, sms, mqtt, webhook, log
    smtp = "mail.example.net:587"
    from = "collector@example.net"
    to = ["ops@example.net"]
    repeat = "4h"                        # re-notify a raised, unacknowledged alarm
    quiet = ["22:00-06:00"]              # held until 06:00 (quiet_mode = "drop": dropped)
    rate = "5/h"                         # the rest of the hour goes out as one summary

Every kind takes ``repeat``, ``quiet``, ``quiet_mode``, ``rate``, ``timezone`` (of the quiet
windows; default the collector's), ``retries`` (failed attempts before giving up; default
never), ``backoff`` and ``backoff_max`` (first retry and the longest wait between tries).
"""

from __future__ import annotations

import re
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from sondalog.config import Table

from .durations import duration, one_or_many, parse_quiet, parse_rate
from .rules import NOTIFY_KINDS, Notify

_COMMON = {"name", "kind", "repeat", "quiet", "quiet_mode", "rate", "retries"}
_COMMON |= {"backoff", "backoff_max", "timezone"}
KEYS: dict[str, set[str]] = {
    "email": _COMMON | {"smtp", "from", "to", "user", "password"},
    "sms": _COMMON | {"via", "url", "from", "device", "baud", "number"},
    "mqtt": _COMMON | {"url", "topic", "discovery", "discovery_prefix"},
    "webhook": _COMMON | {"url", "secret", "timeout"},
    "log": _COMMON | {"level"},
}
_ALL_KEYS = set().union(*KEYS.values())
_HTTP = r"https?://\S+"
_EMAIL = r"[^@\s]+@[^@\s]+"
_PHONE = r"\+?[0-9]{3,20}"


def parse_notify(root: Table) -> dict[str, Notify]:
    """The ``[[notify]]`` tables of ``root`` by name; raises ``ConfigError``."""
    out: dict[str, Notify] = {}
    for table in root.tables("notify", keys=_ALL_KEYS):
        notify = _notify(table)
        if notify.name in out:
            raise table.fail("name", f"{notify.name!r} is used by another [[notify]] table")
        out[notify.name] = notify
    return out


def _notify(t: Table) -> Notify:
    kind = t.text("kind", choices=NOTIFY_KINDS)
    t.keys(KEYS[kind])
    name = t.text("name", pattern=r"[A-Za-z0-9_.-]+", what="a name of letters, digits, - _ .")
    quiet = []
    for i, text in enumerate(one_or_many(t, "quiet") if "quiet" in t else []):
        try:
            quiet.append(parse_quiet(text))
        except ValueError as exc:
            raise t.fail("quiet", f"item {i}: {exc}") from None
    retries = t.opt_integer("retries", lo=1, what="a count of attempts >= 1")
    backoff = duration(t, "backoff", 10.0)
    backoff_max = duration(t, "backoff_max", 3600.0)
    assert backoff is not None and backoff_max is not None
    if backoff_max < backoff:
        raise t.fail("backoff_max", f"must be at least backoff ({backoff:g} s)")
    return Notify(
        name=name,
        kind=kind,
        settings=_SETTINGS[kind](t),
        repeat=duration(t, "repeat"),
        quiet=tuple(quiet),
        quiet_mode="drop"
        if t.text("quiet_mode", "hold", choices=("hold", "drop")) == "drop"
        else "hold",
        rate=t.convert("rate", parse_rate, None),
        retries=retries,
        backoff=backoff,
        backoff_max=backoff_max,
        zone=t.convert("timezone", _zone, None),
        line=t.line(),
    )


def _zone(text: str) -> ZoneInfo:
    try:
        return ZoneInfo(text)
    except (ZoneInfoNotFoundError, ValueError):
        raise ValueError(f'must be a time zone like "Europe/Prague", not {text!r}') from None


def _email(t: Table) -> dict[str, Any]:
    to = one_or_many(t, "to")
    for address in to:
        if not _matches(_EMAIL, address):
            raise t.fail("to", f"must be e-mail addresses, not {address!r}")
    return {
        "smtp": t.address("smtp"),
        "from": t.text("from", pattern=_EMAIL, what="an e-mail address"),
        "to": tuple(to),
        "user": t.opt_text("user"),
        "password": t.opt_text("password"),
    }


def _sms(t: Table) -> dict[str, Any]:
    via = t.text("via", choices=("network", "modem"))
    numbers = one_or_many(t, "number")
    for number in numbers:
        if not _matches(_PHONE, number):
            raise t.fail("number", f"must be phone numbers like +420700000001, not {number!r}")
    if via == "network":
        for key in ("device", "baud"):
            if key in t:
                raise t.fail(key, 'is for via = "modem"; via = "network" takes url and from')
        return {
            "via": via,
            "url": t.text("url", pattern=_HTTP, what="an http:// URL"),
            "from": t.text("from", pattern=_PHONE, what="the phone number the SMS come from"),
            "number": tuple(numbers),
        }
    for key in ("url", "from"):
        if key in t:
            raise t.fail(key, 'is for via = "network"; via = "modem" takes device and baud')
    return {
        "via": via,
        "device": t.path("device"),
        "baud": t.integer("baud", 9600, lo=1, what="a baud rate"),
        "number": tuple(numbers),
    }


def _mqtt(t: Table) -> dict[str, Any]:
    return {
        "url": t.text("url", pattern=r"mqtts?://\S+", what="an mqtt:// URL"),
        "topic": t.text("topic", "sondalog/alarms", pattern=r"[^#+\s]+", what="a topic prefix"),
        "discovery": t.flag("discovery", True),
        "discovery_prefix": t.text("discovery_prefix", "homeassistant"),
    }


def _webhook(t: Table) -> dict[str, Any]:
    return {
        "url": t.text("url", pattern=_HTTP, what="an http:// or https:// URL"),
        "secret": t.opt_text("secret"),
        "timeout": t.number("timeout", 10.0, above=0),
    }


def _log(t: Table) -> dict[str, Any]:
    return {"level": t.text("level", "warning", choices=("info", "warning", "error"))}


_SETTINGS = {"email": _email, "sms": _sms, "mqtt": _mqtt, "webhook": _webhook, "log": _log}


def _matches(pattern: str, text: str) -> bool:
    return re.fullmatch(pattern, text) is not None

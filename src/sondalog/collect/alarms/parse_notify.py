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
never), ``backoff`` and ``backoff_max`` (first retry and the longest wait between tries):
they are read here. The rest of the table is the kind's own: the ``parse`` registered with
its sender (:func:`~.senders.register_sender`) checks it and returns its typed settings.
"""

from __future__ import annotations

from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from sondalog.config import Table

from .durations import duration, one_or_many, parse_quiet, parse_rate
from .rules import Notify
from .senders import SenderKind, SenderUnavailable, find_sender, known_kinds


def parse_notify(root: Table) -> dict[str, Notify[Any]]:
    """The ``[[notify]]`` tables of ``root`` by name; raises ``ConfigError``."""
    out: dict[str, Notify[Any]] = {}
    for table in root.tables("notify"):
        notify = _notify(table)
        if notify.name in out:
            raise table.fail("name", f"{notify.name!r} is used by another [[notify]] table")
        out[notify.name] = notify
    return out


def _sender(t: Table) -> SenderKind[Any]:
    """The registration of the table's ``kind`` (its module imported)."""
    kind = t.text("kind", choices=tuple(known_kinds()))
    try:
        found = find_sender(kind)
    except SenderUnavailable as exc:
        raise t.fail("kind", str(exc)) from None
    if found is None:  # known_kinds() lists every kind find_sender knows
        raise t.fail("kind", f"no sender for notifications of kind {kind!r} is registered")
    return found


def _notify(t: Table) -> Notify[Any]:
    sender = _sender(t)
    settings = sender.parse(t)  # checks the keys: the common ones and the kind's own
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
        kind=sender.kind,
        settings=settings,
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

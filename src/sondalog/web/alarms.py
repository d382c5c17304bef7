"""The alarms the dashboard shows, read from the collector's store (issue 21).

The collector keeps its alarms in its own SQLite file (``alarm_states``, ``alarm_events``,
``alarm_acks``: :mod:`sondalog.collect.alarms.schema`). The dashboard reads them over its
read-only connection; a store made before the alarms (no such tables) simply has none.
The one write is an acknowledgement asked for with the button: the app opens an
:class:`~sondalog.collect.alarms.store.AlarmStore` for it alone (``request_ack``), and the
collector applies it on its next turn.

A POST changes something, so it must come from the dashboard's own pages
(:func:`cross_site`): its ``Origin`` (else ``Referer``) must name the host the request was
sent to. Without a token the dashboard only listens on loopback, and that host must be a
loopback name too (a page of another site whose name was made to point at 127.0.0.1 -- DNS
rebinding -- sends its own name as ``Host`` and ``Origin``).
"""

from __future__ import annotations

import sqlite3
from datetime import UTC, datetime
from typing import Any
from urllib.parse import urlsplit

from sondalog.config import is_loopback

#: The states of an alarm that is on (as :data:`sondalog.collect.alarms.events.ACTIVE`).
ACTIVE = ("raised", "acknowledged")
#: How many transitions the log page and ``/api/alarms`` show.
HISTORY = 50


def host_time(epoch: object) -> str | None:
    """Seconds since the epoch as an ISO time of this computer's clock (with its offset),
    the form the pages show like every other time of this computer."""
    if epoch is None:
        return None
    when = datetime.fromtimestamp(float(epoch), UTC).astimezone()  # type: ignore[arg-type]
    return when.isoformat(timespec="seconds")


def _tables(conn: sqlite3.Connection) -> set[str]:
    rows = conn.execute(
        "SELECT name FROM sqlite_master WHERE type = 'table' AND name LIKE 'alarm_%'"
    )
    return {str(r[0]) for r in rows}


def logger_of(subject: str, source_loggers: dict[str, str]) -> str | None:
    """The logger an alarm is about: ``LOGGER/CHANNEL`` (readings), a source's logger
    (contacts), else the subject itself (health, the collector's sinks: may be no logger)."""
    head, sep, tail = subject.rpartition("/")
    if sep and head and tail.isdigit():
        return head
    return source_loggers.get(subject, subject)


def active(conn: sqlite3.Connection, sources: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The alarms on now (raised or acknowledged), newest first, each with the logger it is
    about and whether an acknowledgement was asked for and waits for the collector."""
    tables = _tables(conn)
    if "alarm_states" not in tables:
        return []
    waiting: set[str] = set()
    if "alarm_acks" in tables:
        waiting = {
            str(r[0]) for r in conn.execute("SELECT alarm FROM alarm_acks WHERE done IS NULL")
        }
    loggers = {str(s["name"]): str(s["logger"]) for s in sources if s.get("logger")}
    rows = conn.execute(
        "SELECT alarm, rule, kind, subject, state, value, text, since, raised_at, acked_at "
        "FROM alarm_states WHERE state IN ('raised', 'acknowledged') "
        "ORDER BY coalesce(raised_at, since) DESC, alarm"
    )
    out = []
    for alarm, rule, kind, subject, state, value, text, since, raised_at, acked_at in rows:
        start = raised_at if raised_at is not None else since
        out.append(
            {
                "id": alarm,
                "rule": rule,
                "kind": kind,
                "subject": subject,
                "logger": logger_of(str(subject), loggers),
                "state": state,
                "value": value,
                "text": text,
                "since": start,
                "since_time": host_time(start),
                "acked_at": acked_at,
                "acked_time": host_time(acked_at),
                "ack_requested": state == "raised" and alarm in waiting,
            }
        )
    return out


def history(conn: sqlite3.Connection, limit: int = HISTORY) -> list[dict[str, Any]]:
    """The latest transitions (raised, cleared, acknowledged), newest first."""
    if "alarm_events" not in _tables(conn):
        return []
    rows = conn.execute(
        "SELECT time, what, alarm, rule, subject, value, text FROM alarm_events "
        "ORDER BY time DESC, id DESC LIMIT ?",
        (limit,),
    )
    keys = ("time", "what", "id", "rule", "subject", "value", "text")
    out = [dict(zip(keys, row, strict=True)) for row in rows]
    for item in out:
        item["host_time"] = host_time(item["time"])
    return out


def state_of(conn: sqlite3.Connection, alarm: str) -> str | None:
    """The alarm's state, or None when there is no such alarm (or no alarm tables)."""
    if "alarm_states" not in _tables(conn):
        return None
    row = conn.execute("SELECT state FROM alarm_states WHERE alarm = ?", (alarm,)).fetchone()
    return None if row is None else str(row[0])


def cross_site(headers: dict[str, str], *, token_set: bool) -> str | None:
    """Why a POST with these (lower-case) ``headers`` is refused as not coming from the
    dashboard's own pages, or None when it may go on.

    Its ``Origin`` (or, without one, its ``Referer``) must name the ``Host`` it was sent to.
    With a token set, a request with neither (a script with ``Authorization: Bearer``) may
    go on: the token is the proof. Without a token a POST must carry one of them, and the
    host must be a loopback name (the dashboard then listens on loopback only).
    """
    host = headers.get("host", "").lower()
    origin = headers.get("origin")
    referer = headers.get("referer")
    claimed = origin if origin is not None else referer
    if claimed is None:
        if token_set:
            return None
        return "a POST must come from the dashboard's own page (no Origin or Referer header)"
    parts = urlsplit(claimed)
    if parts.scheme not in ("http", "https") or parts.netloc.lower() != host:
        return f"cross-site request refused: {claimed!r} is not this dashboard ({host})"
    if not token_set and not is_loopback((urlsplit("//" + host).hostname or "").strip("[]")):
        return f"cross-site request refused: {host} is not a loopback address"
    return None

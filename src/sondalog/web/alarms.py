"""The alarms the dashboard shows, read from wherever the collector keeps them (issue 21).

The collector keeps its alarm tables (``alarm_states``, ``alarm_events``, ``alarm_acks``:
:mod:`sondalog.collect.alarms.schema`) in its own SQLite file, or with ``[postgres] alarms
= true`` on the PostgreSQL server. :class:`AlarmAccess` reaches either through the
collector's alarm store (:class:`~sondalog.collect.alarms.store.SqlAlarmStore`, the same
statements on both): on the file a read-only connection for each look (nothing is
created; a store made before the alarms, without their tables, simply has none) and a
writable one for an acknowledgement; on the server one connection, kept and used by one
request at a time. The one write is an acknowledgement asked for with the button
(``request_ack``); the collector applies it on its next turn.

A POST changes something, so it must come from the dashboard's own pages
(:func:`cross_site`): its ``Origin`` (else ``Referer``) must name the host the request was
sent to. Without a token the dashboard only listens on loopback, and that host must be a
loopback name too (a page of another site whose name was made to point at 127.0.0.1 -- DNS
rebinding -- sends its own name as ``Host`` and ``Origin``).
"""

from __future__ import annotations

import sqlite3
import threading
from collections.abc import Callable
from datetime import UTC, datetime
from typing import Any, TypeVar
from urllib.parse import urlsplit

from sondalog.collect.alarms.store import AlarmStore, AlarmTablesMissing, SqlAlarmStore
from sondalog.config import is_loopback

from .store import StoreUnavailable

#: The states of an alarm that is on (as :data:`sondalog.collect.alarms.events.ACTIVE`).
ACTIVE = ("raised", "acknowledged")
#: How many transitions the log page and ``/api/alarms`` show.
HISTORY = 50

T = TypeVar("T")


class AlarmAccess:
    """The dashboard's way to the collector's alarm store ``store`` (not opened here: an
    :class:`AlarmStore` names the file, a PostgreSQL store is opened on first use)."""

    def __init__(self, store: SqlAlarmStore) -> None:
        self.store = store
        self._lock = threading.Lock()

    @property
    def where(self) -> str:
        """The store in answers (never a DSN: it may hold a password)."""
        if isinstance(self.store, AlarmStore):
            return str(self.store.path)
        if isinstance(self.store, NoAlarmStore):
            return self.store.where
        return "the [postgres] server"

    def run(self, work: Callable[[SqlAlarmStore], T], default: T, *, write: bool = False) -> T:
        """``work`` on the store (call it in a worker thread); ``default`` when the store has
        no alarm tables. Raises :class:`~.store.StoreUnavailable` when it cannot be read."""
        try:
            if isinstance(self.store, AlarmStore):
                with AlarmStore(self.store.path, read_only=not write) as store:
                    return work(store)
            with self._lock:
                return work(self.store.open())
        except AlarmTablesMissing:
            return default
        except self.store.errors as exc:
            raise StoreUnavailable(f"the alarms on {self.where} cannot be read: {exc}") from exc

    def close(self) -> None:
        with self._lock:
            self.store.close()


class NoAlarmStore(SqlAlarmStore):
    """No alarm store was named (``python -m sondalog.web`` on a server without
    ``--file``): every look fails, so the pages say the alarms are unavailable rather than
    that there are none (the collector may keep them anywhere)."""

    errors = (sqlite3.Error,)

    @property
    def where(self) -> str:
        return "no alarm store (give the collector's file with --file)"

    def _connect(self) -> Any:
        raise sqlite3.OperationalError("no alarm store was given")


def host_time(epoch: object) -> str | None:
    """Seconds since the epoch as an ISO time of this computer's clock (with its offset),
    the form the pages show like every other time of this computer."""
    if epoch is None:
        return None
    when = datetime.fromtimestamp(float(epoch), UTC).astimezone()  # type: ignore[arg-type]
    return when.isoformat(timespec="seconds")


def logger_of(subject: str, source_loggers: dict[str, str]) -> str | None:
    """The logger an alarm is about: ``LOGGER/CHANNEL`` (readings), a source's logger
    (contacts), else the subject itself (health, the collector's sinks: may be no logger)."""
    head, sep, tail = subject.rpartition("/")
    if sep and head and tail.isdigit():
        return head
    return source_loggers.get(subject, subject)


def active(store: SqlAlarmStore, sources: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The alarms on now (raised or acknowledged), newest first, each with the logger it is
    about (``sources``: the collector's sources, which name their loggers) and whether an
    acknowledgement was asked for and waits for the collector."""
    waiting = store.waiting_acks()
    loggers = {str(s["name"]): str(s["logger"]) for s in sources if s.get("logger")}
    out = []
    for r in store.active_states():
        start = r.raised_at if r.raised_at is not None else r.since
        out.append(
            {
                "id": r.alarm,
                "rule": r.rule,
                "kind": r.kind,
                "subject": r.subject,
                "logger": logger_of(r.subject, loggers),
                "state": r.state,
                "value": r.value,
                "text": r.text,
                "since": start,
                "since_time": host_time(start),
                "acked_at": r.acked_at,
                "acked_time": host_time(r.acked_at),
                "ack_requested": r.state == "raised" and r.alarm in waiting,
            }
        )
    return out


def history(store: SqlAlarmStore, limit: int = HISTORY) -> list[dict[str, Any]]:
    """The latest transitions (raised, cleared, acknowledged), newest first."""
    keys = ("time", "what", "id", "rule", "subject", "value", "text")
    out = [dict(zip(keys, row, strict=True)) for row in store.history(limit)]
    for item in out:
        item["host_time"] = host_time(item["time"])
    return out


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

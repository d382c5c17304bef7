"""``sondalog alarms``: the alarms a collector keeps in its store, and acknowledging one
(issue 21). The command only parses; the work is here.

Both read the collector's file (``FILE.toml``) for the store's path and open the alarm
tables there, beside a running collector (SQLite WAL), or on the ``[postgres]`` server when
its table says ``alarms = true``. An acknowledgement is a request
(:meth:`~sondalog.collect.alarms.AlarmStore.request_ack`): the collector applies it on its
next turn (within about a second), which stops the alarm's repeats.
"""

from __future__ import annotations

import getpass
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from sondalog.collect.alarm_loop import alarm_store
from sondalog.collect.alarms import AlarmRecord, AlarmStore
from sondalog.collect.config import load_config

if TYPE_CHECKING:
    from sondalog.collect.alarm_loop import Store


class AlarmRefused(Exception):
    """The alarm cannot be acknowledged (unknown id, or not raised); the text says why."""


@dataclass(frozen=True, slots=True)
class AlarmList:
    """What ``alarms list`` shows: the alarms (active ones, or every one) and the latest
    transitions (with ``--all``), newest first."""

    store: Path | str
    alarms: list[AlarmRecord]
    history: list[tuple[object, ...]]


def _store(config_file: Path) -> tuple[Path | str, Store | None]:
    """Where the alarm tables are, and their store (``None``: an SQLite file not there)."""
    config = load_config(config_file)
    store = alarm_store(config)
    if not isinstance(store, AlarmStore):
        return "the [postgres] server", store
    return config.store, store if config.store.exists() else None


def list_alarms(config_file: Path, every: bool = False, limit: int = 100) -> AlarmList:
    """The alarms of the collector of ``config_file`` (raises ``ConfigError``)."""
    path, found = _store(config_file)
    if found is None:
        return AlarmList(path, [], [])
    with found as store:
        shown = store.load_states() if every else store.active_states()
        history = store.history(limit) if every else []
    shown.sort(key=lambda r: (not r.active, -(r.since or 0.0), r.alarm))
    return AlarmList(path, shown, history)


def acknowledge(config_file: Path, alarm: str, by: str | None = None) -> AlarmRecord:
    """Ask the collector of ``config_file`` to acknowledge ``alarm`` (its id); raises
    :class:`AlarmRefused` for an unknown id or an alarm that is not raised."""
    path, found = _store(config_file)
    if found is None:
        raise AlarmRefused(f"no alarm {alarm!r}: the store {path} does not exist yet")
    who = by if by is not None else f"{getpass.getuser()} (command line)"
    with found as store:
        record = next((r for r in store.load_states() if r.alarm == alarm), None)
        if record is None:
            raise AlarmRefused(f"no alarm {alarm!r} in {path} (sondalog alarms list shows them)")
        if record.state != "raised":
            raise AlarmRefused(
                f"alarm {alarm} is {record.state}, not raised: nothing to acknowledge"
            )
        if not store.request_ack(alarm, who, time.time()):
            raise AlarmRefused(f"alarm {alarm} is no longer raised")
    return record


def when(seconds: float | None) -> str:
    """Seconds since the epoch as local ``YYYY-MM-DD HH:MM:SS`` (``-`` for none)."""
    if seconds is None:
        return "-"
    return datetime.fromtimestamp(seconds).strftime("%Y-%m-%d %H:%M:%S")


def value_text(value: object) -> str:
    return "-" if value is None else f"{value:g}" if isinstance(value, float) else str(value)


def table_lines(listing: AlarmList) -> list[str]:
    """The listing as text lines (a header and one line per alarm, then the history)."""
    if not listing.alarms and not listing.history:
        return [f"no alarms in {listing.store}"]
    lines = [f"{'ID':<10}  {'STATE':<12}  {'SINCE':<19}  {'VALUE':>8}  RULE / SUBJECT"]
    for r in listing.alarms:
        lines.append(
            f"{r.alarm:<10}  {r.state:<12}  {when(r.since):<19}  {value_text(r.value):>8}  "
            f"{r.rule} / {r.subject}"
        )
    if listing.history:
        lines += ["", "history (newest first):"]
        for t, what, alarm, rule, subject, value, _text in listing.history:
            seconds = float(t) if isinstance(t, (int, float)) else None
            lines.append(
                f"{when(seconds):<19}  {what!s:<12}  {alarm!s:<10}  {value_text(value):>8}  "
                f"{rule} / {subject}"
            )
    return lines

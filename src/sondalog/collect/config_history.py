"""The collector's record of each logger's configuration (issue 22): two tables of its SQLite
store, created with the other additive tables (``SQLITE_ADDITIVE_DDL`` of
:mod:`sondalog.collect.schema`, where they are written down).

- ``config_history``: one row per configuration a source's logger was seen with: the first
  one read (``old_hash`` NULL, ``diff`` empty) and every change after it (``diff``: one line
  per setting, ``channel 3 sampling period: 000500 -> 000100``, as ``logger config plan``
  prints it). ``config`` holds the whole configuration after the change (JSON, setting name ->
  value as the logger reads it back, §6.1), so the next contact diffs against it, also after a
  restart, and any past configuration can be taken back (``logger config pull`` shape).
- ``config_state``: per source, the last check and the drift from its ``expect`` file
  (``drift``: settings that differ; NULL when the source has no ``expect``), what a ``health``
  alarm with ``measure = "drift"`` watches.

Plain functions over the collector's ``sqlite3.Connection``; the dashboard reads the history
with its own (:mod:`sondalog.web.config_log`).
"""

from __future__ import annotations

import json
import sqlite3
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Known:
    """The configuration last stored for a source's logger."""

    hash: str
    values: dict[str, str]


def last_hash(db: sqlite3.Connection, source: str, logger: str) -> str | None:
    """The hash of the newest ``config_history`` row of ``source`` with ``logger``, or None
    (without reading its configuration: most checks find it unchanged)."""
    row = db.execute(
        "SELECT new_hash FROM config_history WHERE source = ? AND logger = ? "
        "ORDER BY id DESC LIMIT 1",
        (source, logger),
    ).fetchone()
    return None if row is None else str(row[0])


def last(db: sqlite3.Connection, source: str, logger: str) -> Known | None:
    """The newest ``config_history`` row of ``source`` with ``logger``, or None."""
    row = db.execute(
        "SELECT new_hash, config FROM config_history WHERE source = ? AND logger = ? "
        "ORDER BY id DESC LIMIT 1",
        (source, logger),
    ).fetchone()
    if row is None:
        return None
    values = json.loads(row[1])
    return Known(str(row[0]), {str(k): str(v) for k, v in values.items()})


def record(
    db: sqlite3.Connection,
    *,
    source: str,
    logger: str,
    time: str,
    protocol: str,
    old_hash: str | None,
    new_hash: str,
    diff: list[str],
    values: dict[str, str],
) -> None:
    """A history row (in the caller's transaction)."""
    db.execute(
        "INSERT INTO config_history (source, logger, time, protocol, old_hash, new_hash, diff, "
        "config) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
        (
            source,
            logger,
            time,
            protocol,
            old_hash,
            new_hash,
            "\n".join(diff),
            json.dumps(values, ensure_ascii=False, sort_keys=True),
        ),
    )


def set_state(db: sqlite3.Connection, source: str, **columns: Any) -> None:
    """Update ``source``'s ``config_state`` row (created when missing)."""
    db.execute("INSERT OR IGNORE INTO config_state (source) VALUES (?)", (source,))
    if columns:
        sets = ", ".join(f"{c} = ?" for c in columns)
        db.execute(f"UPDATE config_state SET {sets} WHERE source = ?", (*columns.values(), source))


def state(db: sqlite3.Connection, source: str) -> dict[str, Any] | None:
    keys = ("logger", "hash", "checked", "expect", "drift", "drift_text")
    row = db.execute(
        f"SELECT {', '.join(keys)} FROM config_state WHERE source = ?", (source,)
    ).fetchone()
    return None if row is None else dict(zip(keys, row, strict=True))


def drift(db: sqlite3.Connection, source: str) -> float | None:
    """Settings of ``source``'s logger that differ from its ``expect`` file (None: no file,
    or not checked yet): the ``drift`` measure of ``health`` alarms."""
    try:
        row = db.execute("SELECT drift FROM config_state WHERE source = ?", (source,)).fetchone()
    except sqlite3.OperationalError:  # a store without the table
        return None
    return None if row is None or row[0] is None else float(row[0])

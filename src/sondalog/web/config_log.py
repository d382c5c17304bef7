"""The configuration changes of a logger as the collector recorded them (issue 22): rows of
the store's ``config_history`` table (its schema: :mod:`sondalog.collect.schema`), for the
logger page; the log page shows them as the ``config`` events the collector writes with them.
"""

from __future__ import annotations

import sqlite3
from typing import Any

from .db import Db

#: Rows the dashboard shows at most at once.
MAX_SHOWN = 50


def changes(db: Db, *, logger: str | None = None, limit: int = MAX_SHOWN) -> list[dict[str, Any]]:
    """The newest history rows (of ``logger``), newest first, without their ``config``; [] for
    a store that has no history table yet (read-only readers of an older store) and for a
    dashboard without the collector's file (the history is kept there, beside the events)."""
    if db.file is None:
        return []
    conn = db.file
    q = "SELECT id, time, source, logger, old_hash, new_hash, diff FROM config_history"
    params: list[object] = []
    if logger is not None:
        q += " WHERE logger = ?"
        params.append(logger)
    q += " ORDER BY id DESC LIMIT ?"
    params.append(max(1, min(limit, MAX_SHOWN)))
    keys = ("id", "time", "source", "logger", "old_hash", "new_hash", "diff")
    try:
        rows = conn.execute(q, params).fetchall()
    except sqlite3.OperationalError:
        return []
    return [dict(zip(keys, row, strict=True)) for row in rows]

"""What a fleet's loggers hold, read in a few queries for their start (issue 24).

A logger's engine reads its memory when it is built: its parameters, clock, table files and
the end of its record (:class:`~sondalog.backends.store.ala1_nv.LoggerNvStore`), seven
queries of SQLite a logger, 70,000 for a fleet of 10,000. :meth:`NvDatabase.preloaded
<sondalog.backends.store.ala1_nv.NvDatabase.preloaded>` reads all of them at once instead
(one query a table, the newest record page of every logger through the primary key) and
the stores answer from it while the fleet starts. A logger's commit meanwhile (the clock
of a new logger, a value repaired) changes what it holds here as it changes the tables;
after a change of its record the store reads the record from the database again.
"""

from __future__ import annotations

import json
import sqlite3
from collections import defaultdict
from collections.abc import Sequence

from sondalog.ala1.record import RecordChanges
from sondalog.backends.store import record_pages


class Preloaded:
    """Every logger's parameters, meta values, table files and newest record page."""

    __slots__ = ("files", "meta", "newest", "params", "records_changed", "unpaged")

    def __init__(self, conn: sqlite3.Connection, loggers: Sequence[str] = ()) -> None:
        """``loggers``: those of them without any record page are known here too (a new
        fleet: no logger's record is read from the tables)."""
        self.params: defaultdict[str, dict[str, str]] = defaultdict(dict)
        for logger, key, value in conn.execute("SELECT logger, key, value FROM param"):
            self.params[logger][key] = value
        self.meta: defaultdict[str, dict[str, str]] = defaultdict(dict)
        for logger, key, value in conn.execute("SELECT logger, key, value FROM meta"):
            self.meta[logger][key] = str(value)
        self.files: defaultdict[str, dict[str, bytes]] = defaultdict(dict)
        for logger, area, data in conn.execute("SELECT logger, area, data FROM file"):
            self.files[logger][area] = bytes(data)
        self.newest = record_pages.newest_pages(conn)
        self.unpaged = {
            str(logger)
            for (logger,) in conn.execute(
                "SELECT j.value FROM json_each(?) AS j WHERE NOT EXISTS "
                "(SELECT 1 FROM record_page AS p WHERE p.logger = j.value)",
                (json.dumps(list(loggers)),),
            )
        }
        #: Loggers whose record changed since: their record is read from the database.
        self.records_changed: set[str] = set()

    def meta_value(self, logger: str, key: str) -> str | None:
        """A meta value as the table holds it now; None: not known here (or not there),
        see :meth:`knows_meta`."""
        found = self.meta.get(logger)
        return None if found is None else found.get(key)

    def knows_meta(self, logger: str, key: str) -> bool:
        return logger not in self.records_changed or not key.startswith("record")

    def no_pages(self, logger: str) -> bool:
        """Whether ``logger`` is known to have no record page (its record is empty)."""
        return logger in self.unpaged and logger not in self.records_changed

    def newest_page(self, logger: str) -> tuple[record_pages.NewestPage | None] | None:
        """The logger's newest page as read (``(None,)``: none); None: read it again."""
        if logger in self.records_changed:
            return None
        return (self.newest.get(logger),)

    def apply(
        self,
        logger: str,
        changes: dict[str, str | None],
        clock_offset: float | None,
        record: RecordChanges | None,
        seen: float | None,
    ) -> None:
        """A commit of ``logger`` (as the tables get it, ``ala1_nv._apply``)."""
        params = self.params[logger]
        for key, value in changes.items():
            if value is None:
                params.pop(key, None)
            else:
                params[key] = value
        meta = self.meta[logger]
        if clock_offset is not None:
            meta["clock_offset"] = repr(clock_offset)
        if seen is not None:
            meta["host_seen"] = repr(seen)
        if record is not None:
            self.records_changed.add(logger)

"""Alarm states, their history and the notification outbox on SQLite (issue 21).

The tables of :mod:`.schema`, in the collector's store file or one of their own (WAL,
``synchronous=NORMAL``, files 0600 like every store of sondalog). :class:`AlarmStore` is an
:class:`~.outbox.Outbox`, so the policy writes notifications straight into it; run it inside
:meth:`AlarmStore.transaction` together with :meth:`AlarmStore.save_states`, so that a
transition and its notifications are stored together or not at all:

::

    with store.transaction():
        store.record(transitions)
        policy.notify(transitions, now)
        store.save_states(alarms.changed())

A claim is an ``UPDATE`` of due rows in one ``BEGIN IMMEDIATE`` transaction, so two
processes on one file never take the same row while its lease runs.
"""

from __future__ import annotations

import contextlib
import sqlite3
from collections.abc import Iterable, Iterator
from operator import attrgetter, itemgetter
from pathlib import Path

from sondalog.io.private import connect_private, private_parents

from .events import AlarmRecord, StateChanges, Transition
from .outbox import Message, add_line
from .schema import OUTBOX_COLUMNS, SQLITE_ALARM_DDL, STATE_COLUMNS

_STATES = ", ".join(STATE_COLUMNS)
_OUTBOX = ", ".join(OUTBOX_COLUMNS)
_state_values = attrgetter(*STATE_COLUMNS)
#: What the alarm id is a hash of: an upsert leaves them (and their unique index) alone.
_KEY = ("alarm", "rule", "subject")
#: An alarm's row written in place (an upsert, not ``INSERT OR REPLACE``: a known alarm's row
#: keeps its rowid and neither index is touched, which makes saving every reading's counters
#: cheap; the id is a hash of (rule, subject), so the unique pair cannot conflict apart).
_SAVE_STATE = (
    f"INSERT INTO alarm_states ({_STATES}) VALUES ({', '.join('?' * len(STATE_COLUMNS))}) "
    "ON CONFLICT (alarm) DO UPDATE SET "
    + ", ".join(f"{c} = excluded.{c}" for c in STATE_COLUMNS if c not in _KEY)
)
#: The columns of an alarm's rule's progress, which every reading changes.
_COUNTERS = ("count", "last_value", "last_time", "last_counter")
_counter_values = itemgetter(*(STATE_COLUMNS.index(c) for c in (*_COUNTERS, "alarm")))
_SAVE_COUNTERS = (
    f"UPDATE alarm_states SET {', '.join(f'{c} = ?' for c in _COUNTERS)} WHERE alarm = ?"
)


class AlarmStore:
    """The alarm tables in the SQLite file ``path``."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        self._db: sqlite3.Connection | None = None
        self._depth = 0

    # -- opening --------------------------------------------------------------------------

    def open(self) -> AlarmStore:
        if self._db is not None:
            return self
        private_parents(self.path)
        db = connect_private(self.path, isolation_level=None, check_same_thread=False)
        try:
            db.execute("PRAGMA busy_timeout=10000")
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("PRAGMA synchronous=NORMAL")
            db.executescript(SQLITE_ALARM_DDL)
        except BaseException:
            db.close()
            raise
        self._db = db
        return self

    def close(self) -> None:
        if self._db is not None:
            self._db.close()
            self._db = None

    def __enter__(self) -> AlarmStore:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def db(self) -> sqlite3.Connection:
        if self._db is None:
            raise RuntimeError(f"alarm store {self.path} is not open")
        return self._db

    @contextlib.contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """One ``BEGIN IMMEDIATE`` transaction (nested calls join the outer one)."""
        db = self.db
        if self._depth:
            self._depth += 1
            try:
                yield db
            finally:
                self._depth -= 1
            return
        db.execute("BEGIN IMMEDIATE")
        self._depth = 1
        try:
            yield db
        except BaseException:
            db.execute("ROLLBACK")
            raise
        else:
            db.execute("COMMIT")
        finally:
            self._depth = 0

    # -- alarm states ---------------------------------------------------------------------

    def load_states(self) -> list[AlarmRecord]:
        rows = self.db.execute(f"SELECT {_STATES} FROM alarm_states ORDER BY alarm")
        return [AlarmRecord(*row) for row in rows]

    def save_states(self, records: Iterable[AlarmRecord]) -> None:
        rows = [_state_values(r) for r in records]
        if not rows:
            return
        with self.transaction() as db:
            db.executemany(_SAVE_STATE, rows)

    def save_changes(self, changes: StateChanges) -> None:
        """:meth:`Alarms.changes`: whole rows, and the progress columns of the others (a
        row the store does not have yet, say after a failed save, is written whole)."""
        if not changes.states and not changes.counters:
            return
        with self.transaction() as db:
            if changes.states:
                db.executemany(_SAVE_STATE, changes.states)
            if changes.counters:
                rows = [_counter_values(row) for row in changes.counters]
                if db.executemany(_SAVE_COUNTERS, rows).rowcount < len(rows):
                    db.executemany(_SAVE_STATE, changes.counters)

    def record(self, transitions: Iterable[Transition]) -> None:
        """Add ``transitions`` to the history (each (event, what) once)."""
        rows = [
            (t.event, t.what, t.alarm, t.rule, t.subject, t.time, t.value, t.text)
            for t in transitions
        ]
        with self.transaction() as db:
            db.executemany(
                "INSERT OR IGNORE INTO alarm_events "
                "(event, what, alarm, rule, subject, time, value, text) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                rows,
            )

    def history(self, limit: int = 100) -> list[tuple[object, ...]]:
        """The latest transitions, newest first: (time, what, alarm, rule, subject, value,
        text)."""
        return list(
            self.db.execute(
                "SELECT time, what, alarm, rule, subject, value, text FROM alarm_events "
                "ORDER BY time DESC, id DESC LIMIT ?",
                (limit,),
            )
        )

    # -- acknowledgements asked for by people ---------------------------------------------

    def request_ack(self, alarm: str, by: str, now: float) -> bool:
        """Ask the collector to acknowledge ``alarm`` (another process may ask: the dashboard,
        ``sondalog alarms ack``). False if no such alarm is raised now."""
        with self.transaction() as db:
            row = db.execute("SELECT state FROM alarm_states WHERE alarm = ?", (alarm,)).fetchone()
            if row is None or row[0] != "raised":
                return False
            db.execute(
                "INSERT INTO alarm_acks (alarm, by, requested) VALUES (?, ?, ?)", (alarm, by, now)
            )
        return True

    def take_ack_requests(self, now: float) -> list[tuple[str, str, float]]:
        """The acknowledgements asked for and not applied yet, as (alarm, by, requested),
        oldest first; marked applied at ``now`` (commit them with the states they change)."""
        with self.transaction() as db:
            rows = db.execute(
                "SELECT id, alarm, by, requested FROM alarm_acks WHERE done IS NULL ORDER BY id"
            ).fetchall()
            db.executemany(
                "UPDATE alarm_acks SET done = ? WHERE id = ?", [(now, r[0]) for r in rows]
            )
        return [(str(a), str(b), float(t)) for _, a, b, t in rows]

    # -- the outbox -----------------------------------------------------------------------

    def has(self, key: str) -> bool:
        row = self.db.execute("SELECT 1 FROM alarm_outbox WHERE key = ?", (key,)).fetchone()
        return row is not None

    def add(self, message: Message) -> bool:
        marks = ", ".join("?" * len(OUTBOX_COLUMNS))
        values = tuple(getattr(message, c) for c in OUTBOX_COLUMNS)
        with self.transaction() as db:
            cur = db.execute(
                f"INSERT OR IGNORE INTO alarm_outbox ({_OUTBOX}) VALUES ({marks})", values
            )
            return cur.rowcount == 1

    def count_since(self, destination: str, since: float) -> int:
        row = self.db.execute(
            "SELECT count(*) FROM alarm_outbox WHERE destination = ? AND created >= ? "
            "AND what != 'summary' AND state NOT IN ('dropped', 'summarized')",
            (destination, since),
        ).fetchone()
        return int(row[0])

    def extend_summary(self, key: str, line: str) -> bool:
        with self.transaction() as db:
            row = db.execute(
                "SELECT text, items FROM alarm_outbox WHERE key = ? AND state = 'pending' "
                "AND claimed_by IS NULL",
                (key,),
            ).fetchone()
            if row is None:
                return False
            db.execute(
                "UPDATE alarm_outbox SET text = ?, items = items + 1 WHERE key = ?",
                (add_line(row[0], row[1], line), key),
            )
            return True

    def claim(self, now: float, owner: str, lease: float, limit: int = 100) -> list[Message]:
        with self.transaction() as db:
            rows = db.execute(
                f"UPDATE alarm_outbox SET claimed_by = ?, claimed_until = ? WHERE key IN ("
                "SELECT key FROM alarm_outbox WHERE state = 'pending' AND next_try <= ? "
                "AND (claimed_until IS NULL OR claimed_until <= ?) "
                f"ORDER BY next_try, key LIMIT ?) RETURNING {_OUTBOX}",
                (owner, now + lease, now, now, limit),
            ).fetchall()
        return sorted((Message(*row) for row in rows), key=lambda m: (m.next_try, m.key))

    def release(self, owner: str) -> int:
        """Give back the pending rows ``owner`` holds (a restart of a collector killed while
        sending: it sends them again now rather than after the lease); how many."""
        with self.transaction() as db:
            cur = db.execute(
                "UPDATE alarm_outbox SET claimed_by = NULL, claimed_until = NULL "
                "WHERE claimed_by = ? AND state = 'pending'",
                (owner,),
            )
            return cur.rowcount

    def delivered(self, key: str, now: float) -> None:
        with self.transaction() as db:
            db.execute(
                "UPDATE alarm_outbox SET state = 'sent', sent_at = ?, attempts = attempts + 1, "
                "claimed_by = NULL, claimed_until = NULL WHERE key = ?",
                (now, key),
            )

    def failed(self, key: str, now: float, error: str, next_try: float | None) -> None:
        with self.transaction() as db:
            db.execute(
                "UPDATE alarm_outbox SET state = ?, attempts = attempts + 1, last_error = ?, "
                "next_try = coalesce(?, next_try), claimed_by = NULL, claimed_until = NULL "
                "WHERE key = ?",
                ("pending" if next_try is not None else "failed", error, next_try, key),
            )

    def next_try(self) -> float | None:
        row = self.db.execute(
            "SELECT min(max(next_try, coalesce(claimed_until, next_try))) FROM alarm_outbox "
            "WHERE state = 'pending'"
        ).fetchone()
        return None if row[0] is None else float(row[0])

    def messages(self) -> list[Message]:
        rows = self.db.execute(f"SELECT {_OUTBOX} FROM alarm_outbox ORDER BY created, key")
        return [Message(*row) for row in rows]

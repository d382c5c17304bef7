"""The alarm store's methods, written once for SQLite and PostgreSQL (issue 21).

:class:`SqlAlarmStore` holds every statement on the alarm tables (:mod:`.schema`) in the SQL
both servers understand, turned into the server's own by its :class:`~.dialect.Dialect`;
:class:`~.store.AlarmStore` (an SQLite file) and :class:`~.store_pg.PostgresAlarmStore`
(the ``[postgres]`` server) add only how they connect, begin a transaction and notice a
lost connection. It is an :class:`~.outbox.Outbox`, so the policy writes notifications
straight into it; run it inside :meth:`SqlAlarmStore.transaction` together with
:meth:`SqlAlarmStore.save_states`, so that a transition and its notifications are stored
together or not at all (docs/alarms.md "At-least-once, never lost"):

::

    with store.transaction():
        store.record(transitions)
        policy.notify(transitions, now)
        store.save_states(alarms.changed())

What makes a restart neither forget nor notify twice, and several collectors on one
PostgreSQL notify once per event, is in the statements and so the same on both:

- the alarm id is a hash of (rule, subject) and the event id a hash of the alarm and its
  raise time, so a transition computed again (a download read twice, a restart, a second
  collector) finds its history row and its notification's outbox key taken: ``INSERT ...
  ON CONFLICT DO NOTHING`` adds nothing;
- a state is written in place (``INSERT ... ON CONFLICT (alarm) DO UPDATE``), rows in the
  order of their alarm id (two collectors lock them alike: no deadlock);
- a claim is one ``UPDATE ... RETURNING`` of due rows with a lease (:data:`~.schema.CLAIM`;
  ``FOR UPDATE SKIP LOCKED`` on PostgreSQL, ``BEGIN IMMEDIATE`` on SQLite), so a row is
  delivered by one sender while its lease runs;
- an acknowledgement asked for by a person is handed out once to every store that takes
  them (each remembers the last request it saw), so no collector repeats an acknowledged
  alarm.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Iterator, Sequence
from operator import attrgetter, itemgetter
from typing import Any, ClassVar, Self

from .dialect import Dialect
from .events import AlarmRecord, StateChanges, Transition
from .outbox import Message, add_line
from .progress import overlay
from .schema import CLAIM, OUTBOX_COLUMNS, STATE_COLUMNS

#: A connection of either driver (``sqlite3``, psycopg): both have ``execute`` (giving a
#: cursor with ``fetchone``, ``fetchall``, ``rowcount``) and ``cursor`` (``executemany``).
Conn = Any

_STATES = ", ".join(STATE_COLUMNS)
_OUTBOX = ", ".join(OUTBOX_COLUMNS)
_state_values = attrgetter(*STATE_COLUMNS)
#: What the alarm id is a hash of: an upsert leaves them (and their unique index) alone.
_KEY = ("alarm", "rule", "subject")
#: An alarm's row written in place (an upsert, not a delete and insert: a known alarm's row
#: keeps its place and neither index is touched, which makes saving every reading's counters
#: cheap; the id is a hash of (rule, subject), so the unique pair cannot conflict apart).
SAVE_STATE = (
    f"INSERT INTO alarm_states ({_STATES}) VALUES ({', '.join('?' * len(STATE_COLUMNS))}) "
    "ON CONFLICT (alarm) DO UPDATE SET "
    + ", ".join(f"{c} = excluded.{c}" for c in STATE_COLUMNS if c not in _KEY)
)
#: The columns of an alarm's rule's progress, which every observation changes.
_COUNTERS = ("count", "last_value", "last_time", "last_counter")
_counter_values = itemgetter(*(STATE_COLUMNS.index(c) for c in (*_COUNTERS, "alarm")))
SAVE_COUNTERS = (
    f"UPDATE alarm_states SET {', '.join(f'{c} = ?' for c in _COUNTERS)} WHERE alarm = ?"
)
#: The progress of a logger's reading alarms, written in place (:mod:`.progress`).
SAVE_PROGRESS = (
    "INSERT INTO alarm_progress (logger, progress) VALUES (?, ?) "
    "ON CONFLICT (logger) DO UPDATE SET progress = excluded.progress"
)
ADD_EVENT = (
    "INSERT INTO alarm_events (event, what, alarm, rule, subject, time, value, text) "
    "VALUES (?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT (event, what) DO NOTHING"
)
ADD_MESSAGE = (
    f"INSERT INTO alarm_outbox ({_OUTBOX}) VALUES ({', '.join('?' * len(OUTBOX_COLUMNS))}) "
    "ON CONFLICT (key) DO NOTHING"
)
#: The states of an alarm that is on (:data:`~.events.ACTIVE`), newest raise first.
ACTIVE_STATES = (
    f"SELECT {_STATES} FROM alarm_states WHERE state IN ('raised', 'acknowledged') "
    "ORDER BY coalesce(raised_at, since) DESC, alarm"
)
#: When the earliest pending row is due: its ``next_try``, or the end of its lease.
NEXT_TRY = (
    "SELECT min(CASE WHEN claimed_until > next_try THEN claimed_until ELSE next_try END) "
    "FROM alarm_outbox WHERE state = 'pending'"
)


class AlarmTablesMissing(LookupError):
    """A store opened to read (the dashboard) has no alarm tables: no alarms (yet)."""


def _by_alarm(rows: Iterable[Sequence[Any]]) -> list[Sequence[Any]]:
    """Rows in one order (the alarm id, a text, first): two collectors lock them alike, no
    deadlock."""
    return sorted(rows, key=_first)


_first = itemgetter(0)


class SqlAlarmStore:
    """The alarm tables on one server; a subclass says how to reach it."""

    #: How the server spells the statements.
    dialect: ClassVar[Dialect]
    #: The driver's errors (the server went away, a lock waited too long): what a caller
    #: that goes on without the store (the dashboard) catches.
    errors: ClassVar[tuple[type[Exception], ...]]

    def __init__(self) -> None:
        self._db: Conn | None = None
        self._depth = 0
        #: The last acknowledgement request this store has handed out (see the docstring).
        self._ack_mark = 0
        #: Whether the store has ``alarm_progress`` (a file of an older version opened
        #: read-only has not: its progress is all in ``alarm_states``).
        self._progress_table = True

    # -- what each server does its own way ------------------------------------------------

    @property
    def where(self) -> str:
        """The store in messages (a file's path, a server's DSN)."""
        raise NotImplementedError

    def _connect(self) -> Conn:
        """A new connection in autocommit mode, the tables created."""
        raise NotImplementedError

    def _begin(self, db: Conn) -> contextlib.AbstractContextManager[object]:
        """One transaction on ``db``: committed at the end, rolled back on an error."""
        raise NotImplementedError

    def _alive(self, db: Conn) -> bool:
        """False when ``db`` was lost (the server went away): opened again then."""
        return True

    # -- opening --------------------------------------------------------------------------

    def open(self) -> Self:
        if self._db is None or not self._alive(self._db):
            self.close()
            self._db = self._connect()
            row = self._db.execute(
                "SELECT coalesce(max(id), 0) FROM alarm_acks WHERE done IS NOT NULL"
            ).fetchone()
            self._ack_mark = int(row[0]) if row else 0
        return self

    def close(self) -> None:
        db, self._db = self._db, None
        if db is not None:
            with contextlib.suppress(*self.errors):
                db.close()

    def __enter__(self) -> Self:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def db(self) -> Conn:
        if self._db is None:
            raise RuntimeError(f"alarm store {self.where} is not open")
        if not self._depth and not self._alive(self._db):
            self._db = self._connect()  # the server went away and came back: go on
        return self._db

    @contextlib.contextmanager
    def transaction(self) -> Iterator[Conn]:
        """One transaction (nested calls join the outer one)."""
        db = self.db
        if self._depth:
            self._depth += 1
            try:
                yield db
            finally:
                self._depth -= 1
            return
        self._depth = 1
        try:
            with self._begin(db):
                yield db
        finally:
            self._depth = 0

    def _sql(self, text: str) -> str:
        return self.dialect.sql(text)

    def _many(self, db: Conn, text: str, rows: Sequence[Sequence[Any]]) -> int:
        """``text`` for each of ``rows``; how many rows it changed in all."""
        with contextlib.closing(db.cursor()) as cur:
            cur.executemany(self._sql(text), rows)
            return int(cur.rowcount)

    # -- alarm states ---------------------------------------------------------------------

    def load_states(self) -> list[AlarmRecord]:
        """Every alarm's state, with the progress of ``alarm_progress`` where it is newer."""
        db = self.db
        records = [
            AlarmRecord(*row)
            for row in db.execute(f"SELECT {_STATES} FROM alarm_states ORDER BY alarm")
        ]
        if self._progress_table:
            overlay(records, db.execute("SELECT logger, progress FROM alarm_progress"))
        return records

    def active_states(self) -> list[AlarmRecord]:
        """The alarms that are on (raised or acknowledged), the newest raise first."""
        return [AlarmRecord(*row) for row in self.db.execute(ACTIVE_STATES)]

    def state_of(self, alarm: str) -> str | None:
        """The state of ``alarm``, None when there is no such alarm."""
        row = self.db.execute(
            self._sql("SELECT state FROM alarm_states WHERE alarm = ?"), (alarm,)
        ).fetchone()
        return None if row is None else str(row[0])

    def save_states(self, records: Iterable[AlarmRecord]) -> None:
        rows = _by_alarm(_state_values(r) for r in records)
        if rows:
            with self.transaction() as db:
                self._many(db, SAVE_STATE, rows)

    def save_changes(self, changes: StateChanges) -> None:
        """:meth:`Alarms.changes`: whole rows, the progress columns of the others (a row
        the store does not have yet, say after a failed save, is written whole), and the
        loggers' rows of reading alarms' progress (in the order of the logger, after the
        states: two collectors lock rows alike, no deadlock)."""
        if not changes.states and not changes.counters and not changes.progress:
            return
        with self.transaction() as db:
            if changes.states:
                self._many(db, SAVE_STATE, _by_alarm(changes.states))
            if changes.counters:
                whole = _by_alarm(changes.counters)
                rows = [_counter_values(row) for row in whole]
                if self._many(db, SAVE_COUNTERS, rows) < len(rows):
                    update = self._sql(SAVE_COUNTERS)  # which rows are not there?
                    pairs = zip(whole, rows, strict=True)
                    missing = [w for w, r in pairs if not _hit(db, update, r)]
                    self._many(db, SAVE_STATE, missing)
            if len(changes.progress) == 1:  # the common case: a chunk of one logger
                db.execute(self._sql(SAVE_PROGRESS), changes.progress[0])
            elif changes.progress:
                self._many(db, SAVE_PROGRESS, changes.progress)

    def record(self, transitions: Iterable[Transition]) -> None:
        """Add ``transitions`` to the history (each (event, what) once)."""
        rows = [
            (t.event, t.what, t.alarm, t.rule, t.subject, t.time, t.value, t.text)
            for t in transitions
        ]
        if rows:
            with self.transaction() as db:
                self._many(db, ADD_EVENT, rows)

    def history(self, limit: int = 100) -> list[tuple[object, ...]]:
        """The latest transitions, newest first: (time, what, alarm, rule, subject, value,
        text)."""
        rows = self.db.execute(
            self._sql(
                "SELECT time, what, alarm, rule, subject, value, text FROM alarm_events "
                "ORDER BY time DESC, id DESC LIMIT ?"
            ),
            (limit,),
        )
        return [tuple(row) for row in rows]

    # -- acknowledgements asked for by people ---------------------------------------------

    def request_ack(self, alarm: str, by: str, now: float) -> bool:
        """Ask the collectors to acknowledge ``alarm`` (another process may ask: the
        dashboard, ``sondalog alarms ack``). False if no such alarm is raised now."""
        with self.transaction() as db:
            row = db.execute(
                self._sql("SELECT state FROM alarm_states WHERE alarm = ?"), (alarm,)
            ).fetchone()
            if row is None or row[0] != "raised":
                return False
            db.execute(
                self._sql("INSERT INTO alarm_acks (alarm, by, requested) VALUES (?, ?, ?)"),
                (alarm, by, now),
            )
        return True

    def waiting_acks(self) -> set[str]:
        """The alarms with an acknowledgement asked for that no collector applied yet."""
        rows = self.db.execute("SELECT alarm FROM alarm_acks WHERE done IS NULL")
        return {str(row[0]) for row in rows}

    def take_ack_requests(self, now: float) -> list[tuple[str, str, float]]:
        """The requests this store has not handed out yet, as (alarm, by, requested), oldest
        first: the ones no collector applied yet (marked applied at ``now``: commit them with
        the states they change) and the ones another collector applied since (so that this
        one stops repeating them too)."""
        with self.transaction() as db:
            rows = db.execute(
                self._sql(
                    "SELECT id, alarm, by, requested FROM alarm_acks "
                    "WHERE done IS NULL OR id > ? ORDER BY id"
                ),
                (self._ack_mark,),
            ).fetchall()
            if rows:
                done = "UPDATE alarm_acks SET done = ? WHERE id = ? AND done IS NULL"
                self._many(db, done, [(now, r[0]) for r in rows])
        if rows:
            self._ack_mark = max(self._ack_mark, *(int(r[0]) for r in rows))
        return [(str(a), str(b), float(t)) for _, a, b, t in rows]

    # -- the outbox -----------------------------------------------------------------------

    def has(self, key: str) -> bool:
        row = self.db.execute(
            self._sql("SELECT 1 FROM alarm_outbox WHERE key = ?"), (key,)
        ).fetchone()
        return row is not None

    def add(self, message: Message) -> bool:
        values = tuple(getattr(message, c) for c in OUTBOX_COLUMNS)
        with self.transaction() as db:
            return int(db.execute(self._sql(ADD_MESSAGE), values).rowcount) == 1

    def count_since(self, destination: str, since: float) -> int:
        row = self.db.execute(
            self._sql(
                "SELECT count(*) FROM alarm_outbox WHERE destination = ? AND created >= ? "
                "AND what != 'summary' AND state NOT IN ('dropped', 'summarized')"
            ),
            (destination, since),
        ).fetchone()
        return int(row[0]) if row else 0

    def extend_summary(self, key: str, line: str) -> bool:
        with self.transaction() as db:
            row = db.execute(
                self._sql(
                    "SELECT text, items FROM alarm_outbox WHERE key = ? AND state = 'pending' "
                    "AND claimed_by IS NULL{lock}"
                ),
                (key,),
            ).fetchone()
            if row is None:
                return False
            db.execute(
                self._sql("UPDATE alarm_outbox SET text = ?, items = items + 1 WHERE key = ?"),
                (add_line(row[0], row[1], line), key),
            )
            return True

    def claim(self, now: float, owner: str, lease: float, limit: int = 100) -> list[Message]:
        """Due rows for ``owner`` until ``now + lease`` (on PostgreSQL ``SKIP LOCKED``: rows
        another collector is claiming right now are left to it), the earliest due first."""
        with self.transaction() as db:
            rows = db.execute(self._sql(CLAIM), (owner, now + lease, now, now, limit)).fetchall()
        return sorted((Message(*row) for row in rows), key=lambda m: (m.next_try, m.key))

    def release(self, owner: str) -> int:
        """Give back the pending rows ``owner`` holds (a restart of a collector killed while
        sending: it sends them again now rather than after the lease); how many."""
        with self.transaction() as db:
            cur = db.execute(
                self._sql(
                    "UPDATE alarm_outbox SET claimed_by = NULL, claimed_until = NULL "
                    "WHERE claimed_by = ? AND state = 'pending'"
                ),
                (owner,),
            )
            return int(cur.rowcount)

    def delivered(self, key: str, now: float) -> None:
        with self.transaction() as db:
            db.execute(
                self._sql(
                    "UPDATE alarm_outbox SET state = 'sent', sent_at = ?, "
                    "attempts = attempts + 1, claimed_by = NULL, claimed_until = NULL "
                    "WHERE key = ?"
                ),
                (now, key),
            )

    def failed(self, key: str, now: float, error: str, next_try: float | None) -> None:
        with self.transaction() as db:
            db.execute(
                self._sql(
                    "UPDATE alarm_outbox SET state = ?, attempts = attempts + 1, "
                    "last_error = ?, next_try = coalesce(?, next_try), claimed_by = NULL, "
                    "claimed_until = NULL WHERE key = ?"
                ),
                ("pending" if next_try is not None else "failed", error, next_try, key),
            )

    def next_try(self) -> float | None:
        row = self.db.execute(NEXT_TRY).fetchone()
        return None if row is None or row[0] is None else float(row[0])

    def messages(self) -> list[Message]:
        rows = self.db.execute(f"SELECT {_OUTBOX} FROM alarm_outbox ORDER BY created, key")
        return [Message(*row) for row in rows]


def _hit(db: Conn, update: str, row: Sequence[Any]) -> bool:
    """Whether the counters' ``update`` found the alarm's row."""
    return int(db.execute(update, row).rowcount) > 0

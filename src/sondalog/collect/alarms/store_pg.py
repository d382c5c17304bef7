"""Alarm states, their history and the notification outbox on PostgreSQL (issue 21).

The same tables and methods as :class:`~.store.AlarmStore` (the collector uses either), on
the server of the ``[postgres]`` table when it says ``alarms = true`` (docs/alarms.md "On
PostgreSQL"). One synchronous psycopg 3 connection in autocommit mode; a
:meth:`PostgresAlarmStore.transaction` is one server transaction (nested calls join it).

Several collectors may share the tables:

- the alarm id is a hash of (rule, subject) and the event id a hash of the alarm and its
  raise time, so two collectors that see the same readings compute the same raise, and its
  notification the same outbox key: the first insert wins (``ON CONFLICT DO NOTHING``), the
  history keeps one row per (event, what);
- a claim takes due rows ``FOR UPDATE SKIP LOCKED`` (:data:`~.schema.POSTGRES_CLAIM`), so a
  row is delivered by one collector while its lease runs;
- an acknowledgement asked for by a person is seen by every collector once (each remembers
  the last request it saw), so none of them repeats an acknowledged alarm.

A lost connection is opened again by the next transaction; the failing one raises
``psycopg.OperationalError`` (the alarm loop logs it and tries again on its next turn).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Iterator, Sequence
from operator import attrgetter, itemgetter
from typing import Any

import psycopg

from .events import AlarmRecord, StateChanges, Transition
from .outbox import Message, add_line
from .schema import OUTBOX_COLUMNS, POSTGRES_ALARM_DDL, POSTGRES_CLAIM, STATE_COLUMNS

_STATES = ", ".join(STATE_COLUMNS)
_OUTBOX = ", ".join(OUTBOX_COLUMNS)
_state_values = attrgetter(*STATE_COLUMNS)
_KEY = ("alarm", "rule", "subject")
_SAVE_STATE = (
    f"INSERT INTO alarm_states ({_STATES}) VALUES ({', '.join(['%s'] * len(STATE_COLUMNS))}) "
    "ON CONFLICT (alarm) DO UPDATE SET "
    + ", ".join(f"{c} = excluded.{c}" for c in STATE_COLUMNS if c not in _KEY)
)
_COUNTERS = ("count", "last_value", "last_time", "last_counter")
_counter_values = itemgetter(*(STATE_COLUMNS.index(c) for c in (*_COUNTERS, "alarm")))
_SAVE_COUNTERS = (
    f"UPDATE alarm_states SET {', '.join(f'{c} = %s' for c in _COUNTERS)} WHERE alarm = %s"
)
#: Advisory lock of the DDL (two collectors starting together).
_DDL_LOCK = 0x50D4_A1A2

Conn = psycopg.Connection[tuple[Any, ...]]


def _by_alarm(rows: Iterable[Sequence[Any]], at: int = 0) -> list[Sequence[Any]]:
    """Rows in one order (the alarm id): two collectors lock them alike, no deadlock."""
    return sorted(rows, key=lambda r: str(r[at]))


class PostgresAlarmStore:
    """The alarm tables on the PostgreSQL server ``dsn``."""

    def __init__(self, dsn: str, connect_timeout: int = 5) -> None:
        self.dsn = dsn
        self.connect_timeout = connect_timeout
        self._db: Conn | None = None
        self._depth = 0
        #: The last acknowledgement request this store has handed out (see the docstring).
        self._ack_mark = 0

    # -- opening --------------------------------------------------------------------------

    def open(self) -> PostgresAlarmStore:
        if self._db is None or self._db.closed or self._db.broken:
            self._connect()
            with self.transaction() as db:
                row = db.execute(
                    "SELECT coalesce(max(id), 0) FROM alarm_acks WHERE done IS NOT NULL"
                ).fetchone()
            self._ack_mark = int(row[0]) if row else 0
        return self

    def _connect(self) -> None:
        self.close()
        db: Conn = psycopg.connect(self.dsn, autocommit=True, connect_timeout=self.connect_timeout)
        try:
            with db.transaction():
                db.execute("SELECT pg_advisory_xact_lock(%s)", (_DDL_LOCK,))
                db.execute(POSTGRES_ALARM_DDL)
        except BaseException:
            db.close()
            raise
        self._db = db

    def close(self) -> None:
        db, self._db = self._db, None
        if db is not None:
            with contextlib.suppress(psycopg.Error):
                db.close()

    def __enter__(self) -> PostgresAlarmStore:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def db(self) -> Conn:
        if self._db is None:
            raise RuntimeError(f"alarm store {self.dsn} is not open")
        if (self._db.closed or self._db.broken) and not self._depth:
            self._connect()  # the server went away and came back: go on
        return self._db

    @contextlib.contextmanager
    def transaction(self) -> Iterator[Conn]:
        """One transaction on the server (nested calls join the outer one)."""
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
            with db.transaction():
                yield db
        finally:
            self._depth = 0

    # -- alarm states ---------------------------------------------------------------------

    def load_states(self) -> list[AlarmRecord]:
        rows = self.db.execute(f"SELECT {_STATES} FROM alarm_states ORDER BY alarm")
        return [AlarmRecord(*row) for row in rows]

    def save_states(self, records: Iterable[AlarmRecord]) -> None:
        rows = _by_alarm(_state_values(r) for r in records)
        if not rows:
            return
        with self.transaction() as db, db.cursor() as cur:
            cur.executemany(_SAVE_STATE, rows)

    def save_changes(self, changes: StateChanges) -> None:
        """:meth:`Alarms.changes`: whole rows, and the progress columns of the others."""
        if not changes.states and not changes.counters:
            return
        with self.transaction() as db, db.cursor() as cur:
            if changes.states:
                cur.executemany(_SAVE_STATE, _by_alarm(changes.states))
            if changes.counters:
                rows = _by_alarm((_counter_values(row) for row in changes.counters), at=-1)
                missing = []
                for row, full in zip(rows, _by_alarm(changes.counters), strict=True):
                    if cur.execute(_SAVE_COUNTERS, row).rowcount < 1:
                        missing.append(full)
                if missing:
                    cur.executemany(_SAVE_STATE, missing)

    def record(self, transitions: Iterable[Transition]) -> None:
        """Add ``transitions`` to the history (each (event, what) once)."""
        rows = [
            (t.event, t.what, t.alarm, t.rule, t.subject, t.time, t.value, t.text)
            for t in transitions
        ]
        if not rows:
            return
        with self.transaction() as db, db.cursor() as cur:
            cur.executemany(
                "INSERT INTO alarm_events (event, what, alarm, rule, subject, time, value, text) "
                "VALUES (%s, %s, %s, %s, %s, %s, %s, %s) ON CONFLICT (event, what) DO NOTHING",
                rows,
            )

    def history(self, limit: int = 100) -> list[tuple[object, ...]]:
        """The latest transitions, newest first: (time, what, alarm, rule, subject, value,
        text)."""
        return list(
            self.db.execute(
                "SELECT time, what, alarm, rule, subject, value, text FROM alarm_events "
                "ORDER BY time DESC, id DESC LIMIT %s",
                (limit,),
            )
        )

    # -- acknowledgements asked for by people ---------------------------------------------

    def request_ack(self, alarm: str, by: str, now: float) -> bool:
        """Ask the collectors to acknowledge ``alarm``; False if it is not raised now."""
        with self.transaction() as db:
            row = db.execute("SELECT state FROM alarm_states WHERE alarm = %s", (alarm,)).fetchone()
            if row is None or row[0] != "raised":
                return False
            db.execute(
                "INSERT INTO alarm_acks (alarm, by, requested) VALUES (%s, %s, %s)",
                (alarm, by, now),
            )
        return True

    def take_ack_requests(self, now: float) -> list[tuple[str, str, float]]:
        """The requests this store has not handed out yet, as (alarm, by, requested), oldest
        first: the ones no collector applied yet (marked applied at ``now``) and the ones
        another collector applied since (so that this one stops repeating them too)."""
        with self.transaction() as db:
            rows = db.execute(
                "SELECT id, alarm, by, requested FROM alarm_acks "
                "WHERE done IS NULL OR id > %s ORDER BY id",
                (self._ack_mark,),
            ).fetchall()
            if rows:
                db.execute(
                    "UPDATE alarm_acks SET done = %s WHERE done IS NULL AND id = ANY(%s)",
                    (now, [r[0] for r in rows]),
                )
        if rows:
            self._ack_mark = max(self._ack_mark, *(int(r[0]) for r in rows))
        return [(str(a), str(b), float(t)) for _, a, b, t in rows]

    # -- the outbox -----------------------------------------------------------------------

    def has(self, key: str) -> bool:
        row = self.db.execute("SELECT 1 FROM alarm_outbox WHERE key = %s", (key,)).fetchone()
        return row is not None

    def add(self, message: Message) -> bool:
        marks = ", ".join(["%s"] * len(OUTBOX_COLUMNS))
        values = tuple(getattr(message, c) for c in OUTBOX_COLUMNS)
        with self.transaction() as db:
            cur = db.execute(
                f"INSERT INTO alarm_outbox ({_OUTBOX}) VALUES ({marks}) "
                "ON CONFLICT (key) DO NOTHING",
                values,
            )
            return cur.rowcount == 1

    def count_since(self, destination: str, since: float) -> int:
        row = self.db.execute(
            "SELECT count(*) FROM alarm_outbox WHERE destination = %s AND created >= %s "
            "AND what != 'summary' AND state NOT IN ('dropped', 'summarized')",
            (destination, since),
        ).fetchone()
        return int(row[0]) if row else 0

    def extend_summary(self, key: str, line: str) -> bool:
        with self.transaction() as db:
            row = db.execute(
                "SELECT text, items FROM alarm_outbox WHERE key = %s AND state = 'pending' "
                "AND claimed_by IS NULL FOR UPDATE",
                (key,),
            ).fetchone()
            if row is None:
                return False
            db.execute(
                "UPDATE alarm_outbox SET text = %s, items = items + 1 WHERE key = %s",
                (add_line(row[0], row[1], line), key),
            )
            return True

    def claim(self, now: float, owner: str, lease: float, limit: int = 100) -> list[Message]:
        """Due rows for ``owner`` (``SKIP LOCKED``: rows another collector is claiming right
        now are left to it)."""
        args = {"owner": owner, "until": now + lease, "now": now, "limit": limit}
        with self.transaction() as db:
            keys = [str(k) for (k,) in db.execute(POSTGRES_CLAIM, args).fetchall()]
            if not keys:
                return []
            rows = db.execute(
                f"SELECT {_OUTBOX} FROM alarm_outbox WHERE key = ANY(%s) ORDER BY next_try, key",
                (keys,),
            ).fetchall()
        return [Message(*row) for row in rows]

    def release(self, owner: str) -> int:
        """Give back the pending rows ``owner`` holds (a restart after a kill); how many."""
        with self.transaction() as db:
            cur = db.execute(
                "UPDATE alarm_outbox SET claimed_by = NULL, claimed_until = NULL "
                "WHERE claimed_by = %s AND state = 'pending'",
                (owner,),
            )
            return cur.rowcount

    def delivered(self, key: str, now: float) -> None:
        with self.transaction() as db:
            db.execute(
                "UPDATE alarm_outbox SET state = 'sent', sent_at = %s, attempts = attempts + 1, "
                "claimed_by = NULL, claimed_until = NULL WHERE key = %s",
                (now, key),
            )

    def failed(self, key: str, now: float, error: str, next_try: float | None) -> None:
        with self.transaction() as db:
            db.execute(
                "UPDATE alarm_outbox SET state = %s, attempts = attempts + 1, last_error = %s, "
                "next_try = coalesce(%s, next_try), claimed_by = NULL, claimed_until = NULL "
                "WHERE key = %s",
                ("pending" if next_try is not None else "failed", error, next_try, key),
            )

    def next_try(self) -> float | None:
        row = self.db.execute(
            "SELECT min(greatest(next_try, coalesce(claimed_until, next_try))) "
            "FROM alarm_outbox WHERE state = 'pending'"
        ).fetchone()
        return None if row is None or row[0] is None else float(row[0])

    def messages(self) -> list[Message]:
        rows = self.db.execute(f"SELECT {_OUTBOX} FROM alarm_outbox ORDER BY created, key")
        return [Message(*row) for row in rows]

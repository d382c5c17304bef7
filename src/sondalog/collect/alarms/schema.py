"""The alarm tables of the collector's store (issue 21; documented in docs/alarms.md).

Times are seconds since the epoch (UTC) as REAL (PostgreSQL: ``double precision``), the
same numbers the alarm core uses. The tables are additive (``CREATE ... IF NOT EXISTS``):
they may live in the collector's SQLite store beside ``readings`` or in a file of their own.

- ``alarm_states``: one row per alarm (rule, subject) with its state and times, and what its
  rule needs to go on after a restart (``count``, ``last_value``, ``last_time``, ``ref``).
- ``alarm_progress``: one row per logger with the progress of its reading alarms
  (threshold, stuck, step), which every chunk of readings moves (:mod:`.progress`); newer
  than the same columns of ``alarm_states``, which are written with a whole row only.
- ``alarm_events``: the history of transitions, unique on (event, what).
- ``alarm_acks``: acknowledgements asked for by a person (the dashboard's button,
  ``sondalog alarms ack``), applied by the collector on its next turn (``done`` set then).
- ``alarm_outbox``: one row per notification, unique on ``key`` = (event, what,
  destination); ``claimed_by``/``claimed_until`` let several collectors on one PostgreSQL
  share the sending (each row is claimed by one of them at a time).
"""

from __future__ import annotations

from .dialect import POSTGRES

ALARM_SCHEMA_VERSION = 1
#: The alarm tables (a store without them has no alarms yet).
ALARM_TABLES = ("alarm_states", "alarm_events", "alarm_outbox", "alarm_acks")
#: Added later (a store of an older version has none: its progress is in ``alarm_states``).
PROGRESS_TABLE = "alarm_progress"

SQLITE_ALARM_DDL = """
CREATE TABLE IF NOT EXISTS alarm_states (
    alarm        TEXT PRIMARY KEY,
    rule         TEXT NOT NULL,
    kind         TEXT NOT NULL,
    subject      TEXT NOT NULL,
    state        TEXT NOT NULL DEFAULT 'ok'
                 CHECK (state IN ('ok', 'raised', 'acknowledged', 'cleared')),
    event        TEXT,
    value        REAL,
    text         TEXT NOT NULL DEFAULT '',
    since        REAL,
    raised_at    REAL,
    acked_at     REAL,
    cleared_at   REAL,
    count        INTEGER NOT NULL DEFAULT 0,
    last_value   REAL,
    last_time    REAL,
    last_counter INTEGER NOT NULL DEFAULT 0,
    ref          REAL,
    UNIQUE (rule, subject)
);
CREATE TABLE IF NOT EXISTS alarm_progress (
    logger   TEXT PRIMARY KEY,
    progress BLOB NOT NULL
);
CREATE TABLE IF NOT EXISTS alarm_events (
    id      INTEGER PRIMARY KEY AUTOINCREMENT,
    event   TEXT NOT NULL,
    what    TEXT NOT NULL CHECK (what IN ('raised', 'cleared', 'acknowledged')),
    alarm   TEXT NOT NULL,
    rule    TEXT NOT NULL,
    subject TEXT NOT NULL,
    time    REAL NOT NULL,
    value   REAL,
    text    TEXT NOT NULL,
    UNIQUE (event, what)
);
CREATE INDEX IF NOT EXISTS alarm_events_time ON alarm_events (time);
CREATE TABLE IF NOT EXISTS alarm_outbox (
    key           TEXT PRIMARY KEY,
    destination   TEXT NOT NULL,
    what          TEXT NOT NULL CHECK (what IN ('raised', 'cleared', 'repeat', 'summary')),
    event         TEXT NOT NULL,
    text          TEXT NOT NULL,
    created       REAL NOT NULL,
    next_try      REAL NOT NULL,
    alarm         TEXT,
    rule          TEXT,
    subject       TEXT,
    value         REAL,
    time          REAL,
    items         INTEGER NOT NULL DEFAULT 1,
    state         TEXT NOT NULL DEFAULT 'pending'
                  CHECK (state IN ('pending', 'sent', 'failed', 'dropped', 'summarized')),
    attempts      INTEGER NOT NULL DEFAULT 0,
    last_error    TEXT,
    sent_at       REAL,
    claimed_by    TEXT,
    claimed_until REAL
);
CREATE INDEX IF NOT EXISTS alarm_outbox_due ON alarm_outbox (state, next_try);
CREATE INDEX IF NOT EXISTS alarm_outbox_rate ON alarm_outbox (destination, created);
CREATE TABLE IF NOT EXISTS alarm_acks (
    id        INTEGER PRIMARY KEY AUTOINCREMENT,
    alarm     TEXT NOT NULL,
    by        TEXT NOT NULL DEFAULT '',
    requested REAL NOT NULL,
    done      REAL
);
"""

#: The same tables on PostgreSQL (docs/alarms.md), only the types differ.
POSTGRES_ALARM_DDL = (
    SQLITE_ALARM_DDL.replace("INTEGER PRIMARY KEY AUTOINCREMENT", "BIGSERIAL PRIMARY KEY")
    .replace(" REAL", " DOUBLE PRECISION")
    .replace(" INTEGER", " BIGINT")
    .replace(" BLOB", " BYTEA")
)

#: Columns of ``alarm_states`` in the order of :class:`~.events.AlarmRecord`'s fields.
STATE_COLUMNS = (
    "alarm",
    "rule",
    "kind",
    "subject",
    "state",
    "event",
    "value",
    "text",
    "since",
    "raised_at",
    "acked_at",
    "cleared_at",
    "count",
    "last_value",
    "last_time",
    "last_counter",
    "ref",
)
#: Columns of ``alarm_outbox`` in the order of :class:`~.outbox.Message`'s fields.
OUTBOX_COLUMNS = (
    "key",
    "destination",
    "what",
    "event",
    "text",
    "created",
    "next_try",
    "alarm",
    "rule",
    "subject",
    "value",
    "time",
    "items",
    "state",
    "attempts",
    "last_error",
    "sent_at",
    "claimed_by",
    "claimed_until",
)

#: Claiming due outbox rows, written once for both servers (:mod:`.dialect`; parameters:
#: owner, lease end, now, now, limit): the rows come back whole (:data:`OUTBOX_COLUMNS`),
#: in no order. On PostgreSQL ``{skip_locked}`` is ``FOR UPDATE SKIP LOCKED``, which keeps
#: two collectors from taking the same row; on SQLite the ``BEGIN IMMEDIATE`` transaction
#: holds the file.
CLAIM = (
    """
UPDATE alarm_outbox SET claimed_by = ?, claimed_until = ?
WHERE key IN (SELECT key FROM alarm_outbox
              WHERE state = 'pending' AND next_try <= ?
                AND (claimed_until IS NULL OR claimed_until <= ?)
              ORDER BY next_try, key LIMIT ?{skip_locked})
RETURNING """
    + ", ".join(OUTBOX_COLUMNS)
    + "\n"
)
#: :data:`CLAIM` as PostgreSQL runs it (docs/alarms.md).
POSTGRES_CLAIM = POSTGRES.sql(CLAIM)

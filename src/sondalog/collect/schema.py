"""The collector's store schema: the contract shared by the collector, its sinks and the web.

One row per reading, unique on ``(logger, time, counter, channel)`` so that inserts are
idempotent: a record row seen twice (by download and by a data message) is stored once.

- ``logger``: the logger's ``i snumber`` (for an HCTMPS1 module: ``bus:<NAME>``).
- ``channel``: the channel number; 0 for a text row (row type 3..9, §6.8.1).
- ``time``: ISO 8601 ``YYYY-MM-DDTHH:MM:SS`` of the logger's own clock (local, drifting);
  ``utc`` the same instant in UTC when the logger's time zone is configured, else NULL.
- ``counter``: the row's ``.c`` counter (the rows written in one second, §6.8).
- ``type``: the record row type (1 scheduled, 2 ``write channel value``, 3..9 text).
- ``value``: the number, or NULL for "no valid value" (an empty field); ``text`` for text rows.
- ``name``/``unit``: the channel's name and unit as the logger reported them.

Additive tables (:data:`SQLITE_ADDITIVE_DDL`) are created on every open of a store of this
version, old or new, without changing ``schema_version``: a sondalog that does not know them
ignores them. ``channels(logger, channel, name, unit, type, format)`` is each logger channel's name,
unit and ``channel type`` (§6.5.6) as last read by the collector; the dashboard draws type-6
channels (sporadic pulses, §6.5.6.4) as bars. ``config_history`` and ``config_state`` are each
logger source's configuration as the collector read it, and its drift from an ``expect`` file
(:mod:`sondalog.collect.config_history`, issue 22).
"""

from __future__ import annotations

SCHEMA_VERSION = 1
#: A reading's columns in exports and the dashboard's CSV download (long form), in order.
COLUMNS = ("logger", "time", "counter", "type", "channel", "value", "text", "name", "unit", "utc")
#: On PostgreSQL of schema version 2 a record row's readings are parallel arrays of
#: ``record_rows`` (:mod:`sondalog.collect.schema_pg`): these columns, one element a reading.
RECORD_ARRAYS = ("channel", "type", "value", "text", "name", "unit")

#: SQLite DDL of schema version 1 (PostgreSQL shows the same columns with its own types in
#: the view ``readings`` over one row a record row: :mod:`sondalog.collect.schema_pg`).
SQLITE_DDL = """
CREATE TABLE IF NOT EXISTS readings (
    logger  TEXT    NOT NULL,
    channel INTEGER NOT NULL,
    time    TEXT    NOT NULL,
    counter INTEGER NOT NULL,
    type    INTEGER NOT NULL,
    value   REAL,
    text    TEXT,
    name    TEXT,
    unit    TEXT,
    utc     TEXT,
    PRIMARY KEY (logger, time, counter, channel)
) WITHOUT ROWID;
CREATE INDEX IF NOT EXISTS readings_time ON readings (time);
CREATE TABLE IF NOT EXISTS sources (
    name         TEXT PRIMARY KEY,
    url          TEXT NOT NULL,
    kind         TEXT NOT NULL,
    logger       TEXT,
    state        TEXT NOT NULL DEFAULT 'new',
    last_contact TEXT,
    last_error   TEXT,
    offset_s     REAL,
    cursor       TEXT,
    record_fill  TEXT,
    signal       REAL,
    credit       REAL
);
CREATE TABLE IF NOT EXISTS events (
    id     INTEGER PRIMARY KEY AUTOINCREMENT,
    time   TEXT NOT NULL,
    source TEXT NOT NULL,
    kind   TEXT NOT NULL,
    text   TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS meta (
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
"""

#: Tables added within version 1 (``CREATE ... IF NOT EXISTS``, run on every open).
SQLITE_ADDITIVE_DDL = """
CREATE TABLE IF NOT EXISTS channels (
    logger  TEXT    NOT NULL,
    channel INTEGER NOT NULL,
    name    TEXT,
    unit    TEXT,
    type    INTEGER,
    format  TEXT,
    PRIMARY KEY (logger, channel)
);
CREATE TABLE IF NOT EXISTS config_history (
    id       INTEGER PRIMARY KEY AUTOINCREMENT,
    source   TEXT NOT NULL,
    logger   TEXT NOT NULL,
    time     TEXT NOT NULL,
    protocol TEXT NOT NULL,
    old_hash TEXT,
    new_hash TEXT NOT NULL,
    diff     TEXT NOT NULL,
    config   TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS config_history_source ON config_history (source, logger, id);
CREATE INDEX IF NOT EXISTS config_history_logger ON config_history (logger, id);
CREATE TABLE IF NOT EXISTS config_state (
    source  TEXT PRIMARY KEY,
    logger  TEXT,
    hash    TEXT,
    checked TEXT,
    expect  TEXT,
    drift   INTEGER,
    drift_text TEXT
);
"""
#: Columns added to additive tables after they first shipped: (table, column, type).
SQLITE_ADDITIVE_COLUMNS = (("channels", "format", "TEXT"),)

#: The per-block extremes the sinks keep for the dashboard's long ranges (issue 24; the
#: tables and statements: :mod:`sondalog.collect.blocks_sql`): their table, the table of the
#: loggers whose rows stored before are not in it yet, and the block lengths (seconds),
#: finest first, each dividing the next and the day.
EXTREMES = "readings_extremes"
EXTREMES_TODO = "readings_extremes_todo"
EXTREMES_SIZES = (1800, 7200, 21600, 86400)

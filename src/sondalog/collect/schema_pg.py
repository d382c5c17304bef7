"""The PostgreSQL schema of the collector's readings, and its migrations.

Version 1 had one row per reading in the table ``readings`` (the columns of
:mod:`sondalog.collect.schema`), its primary key ``(logger, time, counter, channel)``. The
server's work per reading was mostly that key's B-tree (issue 24), so version 2 stores one
row per *record row* (a logger's sample instant, §6.8): the table ``record_rows`` keyed by
``(logger, time, counter)``, the channels' readings in parallel arrays ordered by channel::

    logger text, time timestamp, counter integer, utc timestamptz,
    channel integer[], type smallint[], value float8[], text text[], name text[], unit text[]

``readings`` is now a view with the columns and types of version 1 (an element of the arrays a
row), so the dashboard, exports, the alarm and block queries and users' own queries read it as
before; a filter on ``logger`` and ``time`` reaches ``record_rows``' primary key. An
``INSERT`` into the view (old scripts, tests) goes through an ``INSTEAD OF`` trigger that
merges the reading into its record row; a channel stored already keeps its stored reading
(version 1 refused the duplicate with an error, version 2 ignores it: as the collector does
with a replay).

:func:`migration_plan` lists the steps from a database's ``schema_version`` (``meta``) to
:data:`VERSION`; ``MIGRATIONS[n]`` turns ``n - 1`` into ``n`` (0: no schema yet), and the sink
runs them in one transaction under an advisory lock. Version 1 to 2 moves the rows with one
``INSERT ... SELECT ... GROUP BY`` (``array_agg ... ORDER BY channel``) and drops the old table.
"""

from __future__ import annotations

from sondalog.collect.schema import RECORD_ARRAYS

#: The PostgreSQL schema version this collector writes (SQLite has its own,
#: :data:`sondalog.collect.schema.SCHEMA_VERSION`).
VERSION = 2

HYPERTABLE = "hypertable"
BRIN = "brin"

#: The table of record rows (a TimescaleDB hypertable or BRIN-indexed on ``time``).
TABLE = "record_rows"
#: Its columns in the order of the sink's COPY.
COLUMNS = ("logger", "time", "counter", "utc", "channel", "type", "value", "text", "name", "unit")
#: The per-channel columns (parallel arrays, one element a reading): ``schema.RECORD_ARRAYS``.
ARRAYS = RECORD_ARRAYS

#: Schema version 1: one row per reading (kept: the migration's starting point, tests).
DDL_V1 = """
CREATE TABLE IF NOT EXISTS readings (
    logger  text             NOT NULL,
    channel integer          NOT NULL,
    time    timestamp        NOT NULL,
    counter integer          NOT NULL,
    type    smallint         NOT NULL,
    value   double precision,
    text    text,
    name    text,
    unit    text,
    utc     timestamptz,
    PRIMARY KEY (logger, time, counter, channel)
)
"""

_TABLE = f"""
CREATE TABLE {TABLE} (
    logger  text        NOT NULL,
    time    timestamp   NOT NULL,
    counter integer     NOT NULL,
    utc     timestamptz,
    channel integer[]   NOT NULL,
    type    smallint[]  NOT NULL,
    value   float8[]    NOT NULL,
    text    text[]      NOT NULL,
    name    text[]      NOT NULL,
    unit    text[]      NOT NULL,
    PRIMARY KEY (logger, time, counter)
)
"""

#: The columns and types of version 1's table, one row a reading. By subscript rather than
#: ``unnest``: a query computes only the columns it reads (measured: the week's rows of a
#: 12-channel logger in a quarter of the time of an ``unnest`` of all six arrays).
_VIEW = f"""
CREATE VIEW readings AS
SELECT r.logger, r.channel[i] AS channel, r.time, r.counter, r.type[i] AS type,
       r.value[i] AS value, r.text[i] AS text, r.name[i] AS name, r.unit[i] AS unit, r.utc
FROM {TABLE} r CROSS JOIN LATERAL generate_subscripts(r.channel, 1) AS i
"""

#: The arrays of ``r`` with the channels of ``e`` it has not got, ordered by channel (a
#: channel in both keeps ``r``'s reading).
MERGED = (
    "(SELECT array_agg(c ORDER BY c), array_agg(t ORDER BY c), array_agg(v ORDER BY c), "
    "array_agg(x ORDER BY c), array_agg(n ORDER BY c), array_agg(u ORDER BY c) FROM ("
    "SELECT * FROM unnest({r}.channel, {r}.type, {r}.value, {r}.text, {r}.name, {r}.unit) "
    "UNION ALL SELECT * FROM unnest({e}.channel, {e}.type, {e}.value, {e}.text, {e}.name, "
    "{e}.unit) AS m(c, t, v, x, n, u) WHERE m.c <> ALL({r}.channel)) s(c, t, v, x, n, u))"
)
_SET = f"(channel, type, value, text, name, unit) = {MERGED}"

#: One reading inserted into the view: merged into its record row (a stored channel kept).
_TRIGGER = f"""
CREATE FUNCTION readings_insert() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
    INSERT INTO {TABLE} AS r (logger, time, counter, utc, channel, type, value, text, name, unit)
    VALUES (NEW.logger, NEW.time, NEW.counter, NEW.utc, ARRAY[NEW.channel],
            ARRAY[NEW.type], ARRAY[NEW.value], ARRAY[NEW.text], ARRAY[NEW.name], ARRAY[NEW.unit])
    ON CONFLICT (logger, time, counter) DO UPDATE SET {_SET.format(r="r", e="excluded")}
    WHERE NOT excluded.channel <@ r.channel;
    IF NOT FOUND THEN
        RETURN NULL;
    END IF;
    RETURN NEW;
END $$;
CREATE TRIGGER readings_insert INSTEAD OF INSERT ON readings
    FOR EACH ROW EXECUTE FUNCTION readings_insert()
"""

_FILL = f"""
INSERT INTO {TABLE} (logger, time, counter, utc, channel, type, value, text, name, unit)
SELECT logger, time, counter, min(utc), array_agg(channel ORDER BY channel),
       array_agg(type ORDER BY channel), array_agg(value ORDER BY channel),
       array_agg(text ORDER BY channel), array_agg(name ORDER BY channel),
       array_agg(unit ORDER BY channel)
FROM readings_v1 GROUP BY logger, time, counter
"""

#: ``MIGRATIONS[n]`` turns schema version ``n - 1`` into ``n`` (0: no schema yet). The time
#: index (:func:`layout_ddl`) is applied to ``record_rows`` after them.
MIGRATIONS: dict[int, tuple[str, ...]] = {
    1: (DDL_V1,),
    2: (
        "ALTER TABLE readings RENAME TO readings_v1",
        _TABLE,
        _FILL,
        "DROP TABLE readings_v1",
        _VIEW,
        _TRIGGER,
    ),
}
#: A database without a schema is created at version 2 at once (nothing to move).
CREATE: tuple[str, ...] = (_TABLE, _VIEW, _TRIGGER)


class SchemaTooNew(RuntimeError):
    """The database was migrated by a newer collector: refuse to write into it."""


def migration_plan(current: int, target: int = VERSION) -> list[int]:
    """The migration steps from schema version ``current`` (0 = empty) to ``target``."""
    if current > target:
        raise SchemaTooNew(
            f"postgres: the database has schema version {current}, this collector knows {target}"
        )
    return list(range(current + 1, target + 1))


def statements(current: int, target: int = VERSION) -> list[str]:
    """The SQL of :func:`migration_plan` (an empty database is created at ``target`` at once)."""
    if current == 0 and target == VERSION:
        return list(CREATE)
    return [sql for step in migration_plan(current, target) for sql in MIGRATIONS[step]]


def choose_layout(setting: str, available: bool) -> str:
    """Hypertable or BRIN: ``setting`` is ``auto``/``on``/``off``, ``available`` whether
    ``timescaledb`` is in ``pg_available_extensions``."""
    if setting == "off":
        return BRIN
    if setting == "on":
        if not available:
            raise ValueError("postgres: timescaledb = 'on' but the extension is not available")
        return HYPERTABLE
    if setting == "auto":
        return HYPERTABLE if available else BRIN
    raise ValueError(f"postgres: timescaledb must be auto, on or off, not {setting!r}")


def layout_ddl(layout: str) -> tuple[str, ...]:
    """The statements that give ``record_rows`` its time index for ``layout`` (idempotent)."""
    if layout == HYPERTABLE:
        return (
            "CREATE EXTENSION IF NOT EXISTS timescaledb",
            f"SELECT create_hypertable('{TABLE}', 'time', if_not_exists => TRUE,"
            " migrate_data => TRUE)",
        )
    return (f"CREATE INDEX IF NOT EXISTS {TABLE}_time_brin ON {TABLE} USING brin (time)",)

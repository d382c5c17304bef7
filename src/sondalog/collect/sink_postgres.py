"""The PostgreSQL sink: readings in a ``readings`` table, inserted idempotently by COPY.

Configured by the ``[postgres]`` table::

    [postgres]
    dsn = "host=db.example port=5432 dbname=sensors user=collector"  # or postgresql://...
    timescaledb = "auto"      # "auto" (hypertable when the extension is there), "on", "off"
    connect_timeout = 5       # seconds
    alarms = false            # true: the alarm tables live here too (docs/alarms.md)

The schema (:data:`DDL`, the columns of :mod:`sondalog.collect.schema` with PostgreSQL types)
is created and migrated by the sink when it connects, under an advisory lock so that several
collectors sharing one database do not race; ``meta`` holds ``schema_version`` and
``layout``. A batch is copied (``COPY ... (FORMAT BINARY)``: no text to format here nor to parse
on the server) straight into ``readings``, under a savepoint; when a row of it is there already
(two collectors, a replay after a crash: the primary key refuses it and the whole COPY with it),
the batch is copied into a temporary table instead and moved by ``INSERT ... ON CONFLICT DO
NOTHING``. Either way in one transaction: the whole batch or nothing, and a row seen twice is
stored once. New rows, the usual case, pay only the COPY (about twice the rows a second of the
``ON CONFLICT`` path, see ``benchmarks/bench_collect.py``).

Time index: a TimescaleDB hypertable on ``time`` when the extension is available (or asked
for), otherwise a BRIN index on ``time`` (small, and good for rows that arrive roughly in time
order). See :func:`choose_layout`.

A server that is down or goes away makes :meth:`PostgresSink.write` raise
:class:`SinkUnavailable`; the next write connects again.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import psycopg
from psycopg import conninfo

from sondalog.collect import blocks_sql
from sondalog.collect.model import Reading, SinkUnavailable
from sondalog.collect.schema import SCHEMA_VERSION
from sondalog.collect.sinks import register_sink
from sondalog.config import Table, of

log = logging.getLogger(__name__)

_KEYS = {"dsn", "timescaledb", "connect_timeout", "alarms"}
_LOCK_ID = 0x50D4_1064  # advisory lock of the schema migration ("sondalog")

HYPERTABLE = "hypertable"
BRIN = "brin"

COLUMNS = ("logger", "channel", "time", "counter", "type", "value", "text", "name", "unit", "utc")
#: The columns' types, for the binary COPY (the order of :data:`COLUMNS`, the types of :data:`DDL`).
TYPES = (
    "text",
    "int4",
    "timestamp",
    "int4",
    "int2",
    "float8",
    "text",
    "text",
    "text",
    "timestamptz",
)
_COLS = ", ".join(COLUMNS)
_COPY_NEW = f"COPY readings ({_COLS}) FROM STDIN (FORMAT BINARY)"
_COPY = f"COPY readings_in ({_COLS}) FROM STDIN (FORMAT BINARY)"
_MOVE = f"INSERT INTO readings ({_COLS}) SELECT {_COLS} FROM readings_in ON CONFLICT DO NOTHING"

#: Schema version 1 (the columns of :mod:`sondalog.collect.schema`).
DDL = """
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

#: ``MIGRATIONS[n]`` turns schema version ``n - 1`` into ``n`` (0: no schema yet).
MIGRATIONS: dict[int, tuple[str, ...]] = {1: (DDL,)}


class SchemaTooNew(RuntimeError):
    """The database was migrated by a newer collector: refuse to write into it."""


def migration_plan(current: int, target: int = SCHEMA_VERSION) -> list[int]:
    """The migration steps from schema version ``current`` (0 = empty) to ``target``."""
    if current > target:
        raise SchemaTooNew(
            f"postgres: the database has schema version {current}, this collector knows {target}"
        )
    return list(range(current + 1, target + 1))


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
    """The statements that give ``readings`` its time index for ``layout``."""
    if layout == HYPERTABLE:
        return (
            "CREATE EXTENSION IF NOT EXISTS timescaledb",
            "SELECT create_hypertable('readings', 'time', if_not_exists => TRUE,"
            " migrate_data => TRUE)",
        )
    return ("CREATE INDEX IF NOT EXISTS readings_time_brin ON readings USING brin (time)",)


def _clean(text: str | None) -> str | None:
    """PostgreSQL text cannot hold NUL: a stray one from a line is dropped, not fatal."""
    return text.replace("\x00", "") if text and "\x00" in text else text


def _row(r: Reading) -> tuple[object, ...]:
    return (
        _clean(r.logger),
        r.channel,
        r.time,
        r.counter,
        r.type,
        r.value,
        _clean(r.text),
        _clean(r.name),
        _clean(r.unit),
        r.utc,
    )


async def _copy(
    cur: psycopg.AsyncCursor[tuple[object, ...]], sql: str, rows: list[tuple[object, ...]]
) -> None:
    async with cur.copy(sql) as copy:
        copy.set_types(TYPES)
        for row in rows:
            await copy.write_row(row)


class PostgresSink:
    """Stores readings in PostgreSQL (see the module docstring)."""

    name = "postgres"

    def __init__(self, dsn: str, *, timescaledb: str = "auto", connect_timeout: int = 5) -> None:
        self.dsn = dsn
        self.timescaledb = timescaledb
        self.connect_timeout = connect_timeout
        self.layout: str | None = None
        self.inserted = 0  # rows new to the table (duplicates not counted)
        self._conn: psycopg.AsyncConnection[tuple[object, ...]] | None = None
        self._lock = asyncio.Lock()

    async def open(self) -> None:
        """Connect and migrate now if the server is there; if not, the first write will."""
        async with self._lock:
            try:
                await self._connection()
            except SinkUnavailable as e:
                log.warning("%s", e)

    async def close(self) -> None:
        async with self._lock:
            if self._conn is not None:
                await self._conn.close()
                self._conn = None

    async def write(self, batch: Sequence[Reading]) -> None:
        if not batch:
            return
        async with self._lock:
            conn = await self._connection()
            try:
                rows = [_row(r) for r in batch]
                async with conn.transaction(), conn.cursor() as cur:
                    try:
                        async with conn.transaction():  # a savepoint: new rows, one COPY
                            await _copy(cur, _COPY_NEW, rows)
                    except psycopg.errors.UniqueViolation:  # some are stored: skip those
                        await _copy(cur, _COPY, rows)
                        await cur.execute(_MOVE)
                        self.inserted += max(cur.rowcount, 0)
                    else:
                        self.inserted += len(rows)
                    await blocks_sql.after_batch_postgres(cur, batch)  # the block extremes
            except (psycopg.OperationalError, psycopg.InterfaceError) as e:
                await self._drop()
                raise SinkUnavailable(f"postgres: {e}".strip()) from e

    async def _drop(self) -> None:
        conn, self._conn = self._conn, None
        if conn is not None:
            with contextlib.suppress(psycopg.Error):  # closing a broken connection
                await conn.close()

    async def _connection(self) -> psycopg.AsyncConnection[tuple[object, ...]]:
        if self._conn is not None and not self._conn.broken and not self._conn.closed:
            return self._conn
        await self._drop()
        try:
            conn = await psycopg.AsyncConnection.connect(
                self.dsn, connect_timeout=self.connect_timeout, autocommit=True
            )
        except psycopg.OperationalError as e:
            raise SinkUnavailable(f"postgres: cannot connect: {e}".strip()) from e
        try:
            self.layout = await self._migrate(conn)
            await conn.execute(
                "CREATE TEMP TABLE IF NOT EXISTS readings_in"
                " (LIKE readings INCLUDING DEFAULTS) ON COMMIT DELETE ROWS"
            )
        except (psycopg.OperationalError, psycopg.InterfaceError) as e:
            await conn.close()
            raise SinkUnavailable(f"postgres: {e}".strip()) from e
        except BaseException:
            await conn.close()
            raise
        self._conn = conn
        return conn

    async def _migrate(self, conn: psycopg.AsyncConnection[tuple[object, ...]]) -> str:
        """Create or migrate the schema; return the time layout in use."""
        async with conn.transaction():
            await conn.execute("SELECT pg_advisory_xact_lock(%s)", (_LOCK_ID,))
            await conn.execute(
                "CREATE TABLE IF NOT EXISTS meta (key text PRIMARY KEY, value text NOT NULL)"
            )
            cur = await conn.execute("SELECT key, value FROM meta")
            meta = {str(k): str(v) for k, v in await cur.fetchall()}
            steps = migration_plan(int(meta.get("schema_version", "0")))
            for step in steps:
                for sql in MIGRATIONS[step]:
                    await conn.execute(sql)
            layout = meta.get("layout")
            if layout is None:
                cur = await conn.execute(
                    "SELECT count(*) FROM pg_available_extensions WHERE name = 'timescaledb'"
                )
                row = await cur.fetchone()
                layout = choose_layout(self.timescaledb, bool(row and row[0]))
                layout = await self._apply_layout(conn, layout)
            await conn.execute(
                "INSERT INTO meta (key, value) VALUES ('schema_version', %s), ('layout', %s)"
                " ON CONFLICT (key) DO UPDATE SET value = excluded.value",
                (str(SCHEMA_VERSION), layout),
            )
        if steps:
            log.info("postgres: schema migrated to version %d (%s)", SCHEMA_VERSION, layout)
        return layout

    async def _apply_layout(
        self, conn: psycopg.AsyncConnection[tuple[object, ...]], layout: str
    ) -> str:
        """Give ``readings`` its time index; a failing ``auto`` hypertable falls back to BRIN."""
        try:
            async with conn.transaction():  # a savepoint: a failure here keeps the migration
                for sql in layout_ddl(layout):
                    await conn.execute(sql)
        except psycopg.DatabaseError as e:
            if layout != HYPERTABLE or self.timescaledb != "auto":
                raise
            log.warning("postgres: no hypertable (%s); using a BRIN index on time", e)
            layout = BRIN
            for sql in layout_ddl(layout):
                await conn.execute(sql)
        return layout


@dataclass(frozen=True, slots=True)
class PostgresConfig:
    """The checked ``[postgres]`` table."""

    dsn: str
    timescaledb: str = "auto"
    connect_timeout: int = 5
    #: The collector's alarm tables on this server, shared by the collectors that use it
    #: (:mod:`sondalog.collect.alarms.store_pg`), not in its SQLite store.
    alarms: bool = False


def _dsn(value: str) -> str:
    try:
        conninfo.conninfo_to_dict(value)
    except psycopg.ProgrammingError as e:
        raise ValueError(f"not a valid connection string: {e}") from None
    return value


def parse_config(table: Table) -> PostgresConfig:
    """Check the ``[postgres]`` table (``ConfigError`` names the file, line and field)."""
    table.keys(_KEYS)
    return PostgresConfig(
        dsn=table.convert("dsn", _dsn),
        timescaledb=table.text("timescaledb", "auto", choices=("auto", "on", "off")),
        connect_timeout=table.integer(
            "connect_timeout", 5, lo=1, what="a whole number of seconds >= 1"
        ),
        alarms=table.flag("alarms", False),
    )


def from_config(config: PostgresConfig) -> PostgresSink:
    """The sink of a checked ``[postgres]`` table: the registration's factory."""
    return PostgresSink(
        config.dsn, timescaledb=config.timescaledb, connect_timeout=config.connect_timeout
    )


def create(table: Mapping[str, object]) -> PostgresSink:
    """A PostgreSQL sink straight from a plain ``[postgres]`` mapping (tests, benchmarks)."""
    return from_config(parse_config(of(table, where="postgres")))


register_sink("postgres", from_config, parse_config)

"""The PostgreSQL sink: readings in a ``readings`` table, inserted idempotently by COPY.

Configured by the ``[postgres]`` table::

    [postgres]
    dsn = "host=db.example port=5432 dbname=sensors user=collector"  # or postgresql://...
    timescaledb = "auto"      # "auto" (hypertable when the extension is there), "on", "off"
    connect_timeout = 5       # seconds
    writers = 1               # connections a large batch is split between (1..8)
    alarms = false            # true: the alarm tables live here too (docs/alarms.md)

The schema (:data:`DDL`, the columns of :mod:`sondalog.collect.schema` with PostgreSQL types)
is created and migrated by the sink when it connects, under an advisory lock so that several
collectors sharing one database do not race; ``meta`` holds ``schema_version`` and
``layout``.

Writing a batch (:meth:`PostgresSink.write`): the rows are copied (``COPY ... (FORMAT BINARY)``:
no text to format here nor to parse on the server) straight into ``readings`` in one
transaction. When a row of it is there already (two collectors, a replay after a crash: the
primary key refuses it and the whole COPY with it) the transaction is rolled back and the
batch copied into a temporary table instead and moved by ``INSERT ... ON CONFLICT DO NOTHING``;
after such a batch the next one goes that way at once (a replay brings many), until one
that had no stored row. Either way a row seen twice is stored once.

The server's work per row is mostly the primary key's B-tree, on one core per connection: a
batch of :data:`SPLIT_AT` readings or more is split between ``writers`` connections (default
1: on PostgreSQL 15 here two cost about 15 % more server CPU a reading, the backends meeting
in the table's extension and the BRIN index, and were no faster on 2 shared cores), each part
in its own transaction, concurrently. The batch is acknowledged only when every
part is committed; a part that fails (the server goes away) makes the write raise and the
whole batch is written again later, its stored parts then skipped by the primary key: nothing
lost, nothing twice, only a half-written batch visible for that while. ``benchmarks/
bench_collect.py`` measures it (issue 24: >= 250,000 readings a second).

Time index: a TimescaleDB hypertable on ``time`` when the extension is available (or asked
for), otherwise a BRIN index on ``time`` (small, and good for rows that arrive roughly in time
order). See :func:`choose_layout`.

A server that is down or goes away makes :meth:`PostgresSink.write` raise
:class:`SinkUnavailable`; the next write connects again.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import operator
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

_KEYS = {"dsn", "timescaledb", "connect_timeout", "alarms", "writers"}
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


#: Batches of at least this many readings are split between the writer connections.
SPLIT_AT = 2_000
#: Most writer connections one sink opens.
MAX_WRITERS = 8
#: Deadlocks one part of a batch retries before the batch waits in the buffer.
_DEADLOCKS = 3

Conn = psycopg.AsyncConnection[tuple[object, ...]]
Row = tuple[object, ...]

#: A reading's fields in the order of :data:`COLUMNS` (one C call a reading).
_fields = operator.attrgetter(*COLUMNS)
_logger = operator.attrgetter("logger")


def _clean(text: str | None) -> str | None:
    """PostgreSQL text cannot hold NUL: a stray one from a line is dropped, not fatal."""
    return text.replace("\x00", "") if text and "\x00" in text else text


def _row(r: Reading) -> Row:
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


def rows_of(batch: Sequence[Reading], clean: bool = False) -> list[Row]:
    """The COPY rows of ``batch``; ``clean`` drops NUL characters from its text (the server
    refuses them: :func:`store_part` asks again with ``clean``, a batch without any pays
    nothing for the check)."""
    if clean:
        return [_row(r) for r in batch]
    return list(map(_fields, batch))


def split(batch: Sequence[Reading], n: int) -> Sequence[Sequence[Reading]]:
    """``batch`` in at most ``n`` parts of similar size: by logger when that shares it out
    well (each part's rows then go to other places of the primary key than the other
    parts', so their servers do not wait for each other's pages), else in ``n`` slices. A
    reading's key is in one part only either way when it is there twice (by logger), or
    the parts may wait for each other (slices; see :func:`store_part`)."""
    if n <= 1:
        return [batch]
    by_logger: list[list[Reading]] = [[] for _ in range(n)]
    where: dict[str, int] = {}
    for logger, run in itertools.groupby(batch, key=_logger):
        by_logger[where.setdefault(logger, len(where) % n)].extend(run)
    if len(where) >= n and max(map(len, by_logger)) * n <= len(batch) * 5 // 4:
        return list(by_logger)
    size = -(-len(batch) // n)
    return [batch[i : i + size] for i in range(0, len(batch), size)]


async def _copy(cur: psycopg.AsyncCursor[Row], sql: str, rows: list[Row]) -> None:
    """COPY ``rows``: formatted by psycopg's (compiled) binary formatter, which hands back a
    chunk of about 32 KiB now and then, sent while the server works on the previous one (no
    coroutine a row, as ``write_row`` would be). After each chunk the other parts of the
    batch get their turn, so that every writer's server has work from the start."""
    async with cur.copy(sql) as copy:
        copy.set_types(TYPES)
        format_row = copy.formatter.write_row
        for row in rows:
            if chunk := format_row(row):
                await copy.write(chunk)
                await asyncio.sleep(0)


async def insert_rows(cur: psycopg.AsyncCursor[Row], rows: list[Row], direct: bool) -> int:
    """Insert ``rows`` in the cursor's transaction; the number of rows new to the table.

    ``direct``: one COPY into ``readings`` (raises ``UniqueViolation`` when a row is stored
    already, which aborts the transaction); otherwise through ``readings_in`` and
    ``ON CONFLICT DO NOTHING``."""
    if direct:
        await _copy(cur, _COPY_NEW, rows)
        return len(rows)
    await _copy(cur, _COPY, rows)
    await cur.execute(_MOVE)
    return max(cur.rowcount, 0)


async def store_part(conn: Conn, batch: Sequence[Reading], direct: bool) -> tuple[int, bool]:
    """Store one part of a batch in one transaction of ``conn``: ``(rows new, conflicted)``,
    ``conflicted`` when some were stored already (a replay: the next batch had better go
    through ``ON CONFLICT`` at once)."""
    rows, clean, conflicted, deadlocks = rows_of(batch), False, False, 0
    while True:
        try:
            async with conn.transaction(), conn.cursor() as cur:
                new = await insert_rows(cur, rows, direct)
                # Here the part is written and not yet committed: what must change with the
                # readings runs here, in the same transaction: the dashboard's extremes.
                await blocks_sql.after_batch_postgres(cur, batch, new)
            return new, conflicted or new < len(rows)
        except psycopg.errors.UniqueViolation:
            direct, conflicted = False, True  # rolled back: again, skipping the stored rows
        except psycopg.errors.CharacterNotInRepertoire:
            if clean:
                raise
            rows, clean = rows_of(batch, clean=True), True  # a NUL in a text: drop it
        except psycopg.errors.DeadlockDetected:
            # Another part of this batch (or another collector) holds a row this part has
            # too, and waits for one of these: rolled back; again through ON CONFLICT.
            deadlocks += 1
            if deadlocks > _DEADLOCKS:
                raise
            direct, conflicted = False, True


class PostgresSink:
    """Stores readings in PostgreSQL (see the module docstring)."""

    name = "postgres"

    def __init__(
        self, dsn: str, *, timescaledb: str = "auto", connect_timeout: int = 5, writers: int = 1
    ) -> None:
        self.dsn = dsn
        self.timescaledb = timescaledb
        self.connect_timeout = connect_timeout
        self.writers = max(1, min(writers, MAX_WRITERS))
        self.layout: str | None = None
        self.inserted = 0  # rows new to the table (duplicates not counted)
        self._conns: list[Conn | None] = [None] * self.writers
        self._replay = False  # the last batch had stored rows: go through ON CONFLICT at once
        self._lock = asyncio.Lock()

    async def open(self) -> None:
        """Connect and migrate now if the server is there; if not, the first write will."""
        async with self._lock:
            try:
                await self._connection(0)
            except SinkUnavailable as e:
                log.warning("%s", e)

    async def close(self) -> None:
        async with self._lock:
            for i in range(len(self._conns)):
                await self._drop(i)

    async def write(self, batch: Sequence[Reading]) -> None:
        """Store ``batch``: every row of it is in ``readings`` (once) when this returns."""
        if not batch:
            return
        async with self._lock:
            parts = split(batch, self.writers if len(batch) >= SPLIT_AT else 1)
            conns = [await self._connection(i) for i in range(len(parts))]
            direct = not self._replay
            done = await asyncio.gather(
                *(store_part(c, p, direct) for c, p in zip(conns, parts, strict=True)),
                return_exceptions=True,
            )
            lost: BaseException | None = None
            for i, result in enumerate(done):
                if isinstance(result, psycopg.errors.DeadlockDetected):
                    lost = lost or result  # the connection is fine: the batch waits
                elif isinstance(result, (psycopg.OperationalError, psycopg.InterfaceError)):
                    await self._drop(i)
                    lost = lost or result
                elif isinstance(result, BaseException):
                    raise result
                else:
                    self.inserted += result[0]
            if lost is not None:  # written again later: the stored parts are skipped then
                raise SinkUnavailable(f"postgres: {lost}".strip()) from lost
            self._replay = any(not isinstance(r, BaseException) and r[1] for r in done)

    async def _drop(self, i: int) -> None:
        conn, self._conns[i] = self._conns[i], None
        if conn is not None:
            with contextlib.suppress(psycopg.Error):  # closing a broken connection
                await conn.close()

    async def _connection(self, i: int) -> Conn:
        """Writer connection ``i`` (connected now if need be; the first migrates the schema)."""
        conn = self._conns[i]
        if conn is not None and not conn.broken and not conn.closed:
            return conn
        await self._drop(i)
        try:
            conn = await psycopg.AsyncConnection.connect(
                self.dsn, connect_timeout=self.connect_timeout, autocommit=True
            )
        except psycopg.OperationalError as e:
            raise SinkUnavailable(f"postgres: cannot connect: {e}".strip()) from e
        try:
            if i == 0 or self.layout is None:
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
        self._conns[i] = conn
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
    #: Connections a large batch is split between (:data:`SPLIT_AT`).
    writers: int = 1


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
        writers=table.integer(
            "writers", 1, lo=1, hi=MAX_WRITERS, what=f"a whole number from 1 to {MAX_WRITERS}"
        ),
    )


def from_config(config: PostgresConfig) -> PostgresSink:
    """The sink of a checked ``[postgres]`` table: the registration's factory."""
    return PostgresSink(
        config.dsn,
        timescaledb=config.timescaledb,
        connect_timeout=config.connect_timeout,
        writers=config.writers,
    )


def create(table: Mapping[str, object]) -> PostgresSink:
    """A PostgreSQL sink straight from a plain ``[postgres]`` mapping (tests, benchmarks)."""
    return from_config(parse_config(of(table, where="postgres")))


register_sink("postgres", from_config, parse_config)

"""The PostgreSQL sink: readings in ``record_rows`` (one row a record row), inserted idempotently
by COPY.

Configured by the ``[postgres]`` table::

    [postgres]
    dsn = "host=db.example port=5432 dbname=sensors user=collector"  # or postgresql://...
    timescaledb = "auto"      # "auto" (hypertable when the extension is there), "on", "off"
    connect_timeout = 5       # seconds
    writers = 1               # connections a large batch is split between (1..8)
    alarms = false            # true: the alarm tables live here too (docs/alarms.md)

The schema (:mod:`sondalog.collect.schema_pg`: the table ``record_rows``, one row per record
row with the channels' readings in arrays, and the view ``readings``, one row a reading as in
version 1) is created and migrated by the sink when it connects, under an advisory lock so
that several collectors sharing one database do not race; ``meta`` holds ``schema_version``
and ``layout``.

Writing a batch (:meth:`PostgresSink.write`): the readings are grouped into record rows a piece
at a time (:func:`sondalog.collect.pg_rows.pieces`) and copied (``COPY ... (FORMAT BINARY)``,
:class:`~sondalog.collect.pg_rows.Encoder`) straight into ``record_rows`` in one transaction,
the server storing a piece while the next is made. When a row of it is there already (two
collectors, a replay after a crash: the primary key refuses it and the whole COPY with it) the
transaction is rolled back and the batch copied into a temporary table instead: its new rows
inserted by ``INSERT ... ON CONFLICT DO NOTHING``, and a stored row that lacks some of its
channels (a record row whose readings came in two batches) given them, a channel stored
already keeping its reading. After such a batch the next one goes that way at once (a replay
brings many), until one that had no stored reading. Either way a reading seen twice is stored
once. The dashboard's blocks of the batch are merged in the same transaction, but not those
the sink knows would not change (:class:`~sondalog.collect.blocks_rule.Written`).

The server's work is mostly the primary key's B-tree, one entry a record row (version 1 had
one a reading, about five times the server's CPU: issue 24). A batch of :data:`SPLIT_AT`
readings or more is split between ``writers`` connections (default 1), each part in its own
transaction, concurrently. The batch is acknowledged only when every part is committed; a
part that fails (the server goes away) makes the write raise and the whole batch is written
again later, its stored parts then skipped: nothing lost, nothing twice, only a half-written
batch visible for that while. ``benchmarks/bench_collect.py`` measures it (issue 24: >=
250,000 readings a second).

Time index: a TimescaleDB hypertable on ``time`` when the extension is available (or asked
for), otherwise a BRIN index on ``time`` (small, and good for rows that arrive roughly in time
order). See :func:`~sondalog.collect.schema_pg.choose_layout`.

A server that is down or goes away makes :meth:`PostgresSink.write` raise
:class:`SinkUnavailable`; the next write connects again.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import psycopg
from psycopg import conninfo

from sondalog.collect import blocks_rule, blocks_sql, pg_rows, schema_pg
from sondalog.collect.model import Reading, SinkUnavailable
from sondalog.collect.pg_rows import split
from sondalog.collect.schema_pg import (
    BRIN,
    HYPERTABLE,
    SchemaTooNew,
    choose_layout,
    layout_ddl,
    migration_plan,
)
from sondalog.collect.sinks import register_sink
from sondalog.config import Table, of

log = logging.getLogger(__name__)

__all__ = [
    "BRIN",
    "HYPERTABLE",
    "MAX_WRITERS",
    "SPLIT_AT",
    "PostgresConfig",
    "PostgresSink",
    "SchemaTooNew",
    "choose_layout",
    "create",
    "migration_plan",
    "parse_config",
    "split",
]

_KEYS = {"dsn", "timescaledb", "connect_timeout", "alarms", "writers"}
_LOCK_ID = 0x50D4_1064  # advisory lock of the schema migration ("sondalog")

_COLS = ", ".join(schema_pg.COLUMNS)
_COPY_NEW = f"COPY {schema_pg.TABLE} ({_COLS}) FROM STDIN (FORMAT BINARY)"
_COPY = f"COPY record_rows_in ({_COLS}) FROM STDIN (FORMAT BINARY)"
#: A batch with stored rows: the new rows inserted, the number of their readings.
_MOVE = (
    f"WITH n AS (INSERT INTO {schema_pg.TABLE} ({_COLS}) SELECT {_COLS} FROM record_rows_in"
    " ON CONFLICT DO NOTHING RETURNING cardinality(channel) AS n) SELECT sum(n) FROM n"
)
_JOIN = (
    "(r.logger, r.time, r.counter) = (i.logger, i.time, i.counter) AND NOT i.channel <@ r.channel"
)
#: Then the stored rows that lack some of the batch's channels, locked: how many readings
#: they gain (counted on the row as it is once locked: another collector may merge first).
_LACKING = (
    "SELECT sum(n) FROM (SELECT (SELECT count(*) FROM unnest(i.channel) c"
    f" WHERE c <> ALL(r.channel)) AS n FROM {schema_pg.TABLE} r, record_rows_in i"
    f" WHERE {_JOIN} FOR UPDATE OF r) s"
)
#: ... and those channels merged into them (a channel stored already keeps its reading).
_MERGE = (
    f"UPDATE {schema_pg.TABLE} r SET (channel, type, value, text, name, unit) = "
    f"{schema_pg.MERGED.format(r='r', e='i')} FROM record_rows_in i WHERE {_JOIN}"
)

#: Batches of at least this many readings are split between the writer connections.
SPLIT_AT = 2_000
#: Most writer connections one sink opens.
MAX_WRITERS = 8
#: Deadlocks one part of a batch retries before the batch waits in the buffer.
_DEADLOCKS = 3

Conn = psycopg.AsyncConnection[tuple[object, ...]]
#: The arrays met are encoded once for every batch of the process (encoding is synchronous).
_ENCODER = pg_rows.Encoder()

#: Readings grouped, encoded and sent at a time (256 rows of 8 channels, about 100 KB): the
#: server stores one piece while the next is made.
_PIECE = 2_048


class _Blocks:
    """The dashboard's blocks of a part of a batch, computed while the server stores its
    rows: the pieces sent taken in (:meth:`add`; :class:`blocks_rule.Aggregate` computes
    them mostly once the last is sent, fewer blocks a piece costing less Python), those
    that may change the stored ones once the last is sent (:meth:`done`), in the key's
    order (the server's look-ups then go page after page of its index, measured about a
    fifth less a new block, and concurrent collectors lock blocks in one order)."""

    def __init__(self, written: blocks_rule.Written) -> None:
        self._written = written
        self._aggregate = blocks_rule.Aggregate()
        self.changing: list[tuple[object, ...]] = []

    def add(self, rows: Sequence[pg_rows.Row]) -> None:
        self._aggregate.add(rows)

    def done(self) -> None:
        self.changing = sorted(self._written.changing(self._aggregate.blocks()))


async def _copy(
    cur: psycopg.AsyncCursor[tuple[object, ...]],
    sql: str,
    pieces: Iterable[Sequence[pg_rows.Row]],
    meanwhile: _Blocks | None = None,
) -> int:
    """COPY the record rows of ``pieces`` in the binary format (:class:`pg_rows.Encoder`), a
    piece at a time, so that the server's work overlaps the making of the next piece; after
    each piece the other parts of the batch get their turn. ``meanwhile`` takes each piece
    once it is sent, and is done before the server's answer is awaited: its CPU overlaps
    the server's too. The number of readings copied."""
    copied = 0
    async with cur.copy(sql) as copy:
        head = pg_rows.SIGNATURE
        for rows in pieces:
            await copy.write(head + _ENCODER.body(rows))
            head = b""
            copied += pg_rows.readings_in(rows)
            if meanwhile is not None:
                meanwhile.add(rows)
            await asyncio.sleep(0)
        await copy.write(head + pg_rows.TRAILER)
        if meanwhile is not None:
            meanwhile.done()
    return copied


async def _number(cur: psycopg.AsyncCursor[tuple[object, ...]], sql: str) -> int:
    await cur.execute(sql)
    row = await cur.fetchone()
    return int(str(row[0])) if row and row[0] is not None else 0  # sum(): numeric


async def insert_rows(
    cur: psycopg.AsyncCursor[tuple[object, ...]],
    batch: Sequence[Reading],
    direct: bool,
    meanwhile: _Blocks | None = None,
) -> tuple[int, int]:
    """Insert the record rows of ``batch`` in the cursor's transaction: the number of
    readings new to the table, and of the batch's readings (each counted once).

    ``direct``: one COPY into ``record_rows``, the rows grouped a piece at a time while the
    server stores the piece before (:func:`pg_rows.pieces`; raises ``UniqueViolation`` when
    a row is stored already, and :class:`pg_rows.Apart` when a row's readings are in two
    pieces, either aborting the transaction); otherwise the rows grouped at once
    (:func:`pg_rows.group`) through ``record_rows_in``: new rows inserted, stored rows given
    the channels they lack (a row whose channels came in two batches), nothing stored twice.
    ``meanwhile``: as :func:`_copy`'s."""
    if direct:
        new = await _copy(cur, _COPY_NEW, pg_rows.pieces(batch, _PIECE), meanwhile)
        return new, new
    rows = pg_rows.group(batch)
    total = await _copy(cur, _COPY, (rows[i : i + 256] for i in range(0, len(rows), 256)))
    new = await _number(cur, _MOVE)
    if len(rows) and (gained := await _number(cur, _LACKING)):
        await cur.execute(_MERGE)
        new += gained
    return new, total


async def store_part(
    conn: Conn, batch: Sequence[Reading], direct: bool, written: blocks_rule.Written
) -> tuple[int, bool]:
    """Store one part of a batch in one transaction of ``conn``: ``(readings new,
    conflicted)``, ``conflicted`` when some were stored already (a replay: the next batch
    had better go through ``ON CONFLICT`` at once). ``written``: the sink's blocks known
    stored (:class:`blocks_rule.Written`), which take the part's once committed."""
    conflicted, deadlocks = False, 0
    while True:
        try:
            blocks = _Blocks(written)
            async with conn.transaction(), conn.cursor() as cur:
                # A direct COPY stores every reading or fails: the dashboard's extremes of
                # the part are computed while the server stores its rows.
                new, total = await insert_rows(cur, batch, direct, blocks if direct else None)
                # Here the part is written and not yet committed: what must change with the
                # readings runs here, in the same transaction: the dashboard's extremes
                # (unchanged when no reading was new: a replay reads nothing back).
                if new:
                    await blocks_sql.after_batch_postgres(
                        cur, batch, new, blocks.changing if direct else None
                    )
            if direct and new == len(batch):  # the blocks of every reading were merged
                written.note(blocks.changing)
            return new, conflicted or new < total
        except pg_rows.Apart:
            direct = False  # rolled back: again, the rows grouped at once
        except psycopg.errors.UniqueViolation:
            direct, conflicted = False, True  # rolled back: again, merging into stored rows
        except psycopg.errors.DeadlockDetected:
            # Another collector holds a row this part has too, and waits for one of these:
            # rolled back; again through the temporary table.
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
        self._written = blocks_rule.Written()  # blocks known stored (emptied on connecting)
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
                *(
                    store_part(c, p, direct, self._written)
                    for c, p in zip(conns, parts, strict=True)
                ),
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
        self._written.clear()  # perhaps another server now, or one restored from a backup
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
                "CREATE TEMP TABLE IF NOT EXISTS record_rows_in"
                f" (LIKE {schema_pg.TABLE}) ON COMMIT DELETE ROWS"
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
            steps = schema_pg.statements(int(meta.get("schema_version", "0")))
            for sql in steps:
                await conn.execute(sql)
            layout = meta.get("layout")
            if layout is not None and steps:  # the new table gets the old one's time index
                layout = await self._apply_layout(conn, layout)
            elif layout is None:
                cur = await conn.execute(
                    "SELECT count(*) FROM pg_available_extensions WHERE name = 'timescaledb'"
                )
                row = await cur.fetchone()
                layout = choose_layout(self.timescaledb, bool(row and row[0]))
                layout = await self._apply_layout(conn, layout)
            await conn.execute(
                "INSERT INTO meta (key, value) VALUES ('schema_version', %s), ('layout', %s)"
                " ON CONFLICT (key) DO UPDATE SET value = excluded.value",
                (str(schema_pg.VERSION), layout),
            )
        if steps:
            log.info("postgres: schema migrated to version %d (%s)", schema_pg.VERSION, layout)
        return layout

    async def _apply_layout(
        self, conn: psycopg.AsyncConnection[tuple[object, ...]], layout: str
    ) -> str:
        """Give ``record_rows`` its time index; a failing ``auto`` hypertable falls back to
        BRIN."""
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

"""The lease tables of collectors that share their sources, on PostgreSQL (issue 24).

The statements that carry out a :class:`~sondalog.collect.leases.Plan` (docs/scaling.md
"Collectors that share the work"). Times are seconds since the epoch on the database's clock
(``clock_timestamp()``), so the members' own clocks never decide who holds a source.

- :meth:`LeaseTables.take` is one ``UPDATE`` of at most ``want`` free rows chosen by a
  ``SELECT ... FOR UPDATE SKIP LOCKED`` (rows another member is taking right now are left to
  it) that checks again that each row is free: a source never has two holders;
- :meth:`LeaseTables.renew` and :meth:`LeaseTables.save` change only rows this member holds
  with a lease that has not run out (a member that stalled past its lease finds its rows
  gone and stops);
- a source's ``cursor`` and ``logger`` (what its download resumes after) travel with the
  lease: the next holder starts where the rows on this server stand.

One autocommit connection (psycopg 3, asynchronous); the tables are created under an
advisory lock (collectors starting together).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import psycopg

from sondalog.collect.leases import Lease

#: Advisory lock of the DDL (collectors starting together).
_DDL_LOCK = 0x50D4_1EA5
NOW = "extract(epoch from clock_timestamp())"

DDL = """
CREATE TABLE IF NOT EXISTS collector_members (
    name    text PRIMARY KEY,
    expires double precision NOT NULL
);
CREATE TABLE IF NOT EXISTS collector_leases (
    source       text PRIMARY KEY,
    holder       text,
    expires      double precision NOT NULL DEFAULT 0,
    cursor       text,
    logger       text,
    last_contact double precision
);
CREATE INDEX IF NOT EXISTS collector_leases_holder ON collector_leases (holder);
"""

Conn = psycopg.AsyncConnection[tuple[Any, ...]]


@dataclass(frozen=True, slots=True)
class Taken:
    """A source just taken, with what its download resumes from."""

    source: str
    cursor: str | None
    logger: str | None
    #: The previous holder's last good contact (database clock), None if never.
    last_contact: float | None


@dataclass(frozen=True, slots=True)
class Snapshot:
    now: float
    leases: dict[str, Lease]
    members: dict[str, float]


class LeaseTables:
    """The lease tables on ``dsn`` as member ``me`` with leases of ``lease`` seconds."""

    def __init__(self, dsn: str, me: str, lease: float, connect_timeout: int = 5) -> None:
        self.dsn = dsn
        self.me = me
        self.lease = lease
        self.connect_timeout = connect_timeout
        self._conn: Conn | None = None
        self._connecting = asyncio.Lock()  # the turns and the pollers share the connection

    async def _db(self) -> Conn:
        async with self._connecting:
            if self._conn is not None and not (self._conn.closed or self._conn.broken):
                return self._conn
            await self.close()
            self._conn = await self._connect()
            return self._conn

    async def _connect(self) -> Conn:
        conn = await psycopg.AsyncConnection.connect(
            self.dsn, autocommit=True, connect_timeout=self.connect_timeout
        )
        try:
            async with conn.transaction():
                await conn.execute("SELECT pg_advisory_xact_lock(%s)", (_DDL_LOCK,))
                await conn.execute(DDL)
        except BaseException:
            await conn.close()
            raise
        return conn

    async def close(self) -> None:
        conn, self._conn = self._conn, None
        if conn is not None and not conn.closed:
            with contextlib.suppress(psycopg.Error):  # closing a broken connection
                await conn.close()

    async def join(self, sources: Sequence[str]) -> None:
        """Add the rows of ``sources`` that are not there yet (each file's list)."""
        db = await self._db()
        await db.execute(
            "INSERT INTO collector_leases (source) SELECT unnest(%s::text[])"
            " ON CONFLICT (source) DO NOTHING",
            (list(sources),),
        )

    async def snapshot(self, sources: Sequence[str]) -> Snapshot:
        """Renew this member's row, then read both tables (for ``sources``) and the time."""
        db = await self._db()
        await db.execute(
            f"INSERT INTO collector_members (name, expires) VALUES (%s, {NOW} + %s)"
            " ON CONFLICT (name) DO UPDATE SET expires = excluded.expires",
            (self.me, self.lease),
        )
        cur = await db.execute(
            f"SELECT source, holder, expires, {NOW} FROM collector_leases WHERE source = ANY(%s)",
            (list(sources),),
        )
        rows = await cur.fetchall()
        cur = await db.execute(f"SELECT name, expires, {NOW} FROM collector_members")
        members = await cur.fetchall()
        now = float(members[0][2]) if members else 0.0
        return Snapshot(
            now,
            {str(s): Lease(None if h is None else str(h), float(e)) for s, h, e, _ in rows},
            {str(n): float(e) for n, e, _ in members},
        )

    async def renew(self, sources: Sequence[str]) -> set[str]:
        """Extend the leases of ``sources`` that this member still holds; which ones."""
        if not sources:
            return set()
        db = await self._db()
        cur = await db.execute(
            f"UPDATE collector_leases SET expires = {NOW} + %s"
            f" WHERE source = ANY(%s) AND holder = %s AND expires > {NOW} RETURNING source",
            (self.lease, list(sources), self.me),
        )
        return {str(r[0]) for r in await cur.fetchall()}

    async def take(self, candidates: Sequence[str], want: int) -> list[Taken]:
        """At most ``want`` of ``candidates`` that are free, the first ones first."""
        if want <= 0 or not candidates:
            return []
        db = await self._db()
        cur = await db.execute(
            f"UPDATE collector_leases SET holder = %s, expires = {NOW} + %s"
            " WHERE source IN (SELECT l.source FROM collector_leases l"
            " JOIN unnest(%s::text[]) WITH ORDINALITY AS c(source, rank) ON c.source = l.source"
            f" WHERE l.holder IS NULL OR l.expires <= {NOW}"
            " ORDER BY c.rank LIMIT %s FOR UPDATE OF l SKIP LOCKED)"
            f" AND (holder IS NULL OR expires <= {NOW})"
            " RETURNING source, cursor, logger, last_contact",
            (self.me, self.lease, list(candidates), want),
        )
        rows = await cur.fetchall()
        return [Taken(str(s), c, lg, None if t is None else float(t)) for s, c, lg, t in rows]

    async def release(self, sources: Sequence[str]) -> None:
        """Give ``sources`` back (their pollers stopped first)."""
        if not sources:
            return
        db = await self._db()
        await db.execute(
            "UPDATE collector_leases SET holder = NULL, expires = 0"
            " WHERE source = ANY(%s) AND holder = %s",
            (list(sources), self.me),
        )

    async def save(
        self, source: str, cursor: str | None, logger: str | None, contact: bool
    ) -> bool:
        """Where ``source``'s rows on this server stand (and, ``contact``, that it was
        contacted now); False when this member no longer holds it."""
        db = await self._db()
        contacted = f", last_contact = {NOW}" if contact else ""
        cur = await db.execute(
            "UPDATE collector_leases SET cursor = coalesce(%s, cursor),"
            f" logger = coalesce(%s, logger){contacted}"
            f" WHERE source = %s AND holder = %s AND expires > {NOW}",
            (cursor, logger, source, self.me),
        )
        return cur.rowcount == 1

    async def leave(self) -> None:
        """A clean stop: every lease of this member given back, its row gone."""
        db = await self._db()
        await db.execute(
            "UPDATE collector_leases SET holder = NULL, expires = 0 WHERE holder = %s",
            (self.me,),
        )
        await db.execute("DELETE FROM collector_members WHERE name = %s", (self.me,))

"""Collectors that share their sources through PostgreSQL (issue 24): the turn that runs them.

With a ``[cluster]`` table (docs/scaling.md "Collectors that share the work") the runner does
not start a poller per source; :meth:`Share.run` does, for the sources this member holds:

- every ``lease / 3`` seconds a turn renews the member's row, reads the lease tables,
  and carries out :func:`~sondalog.collect.leases.plan`: pollers of released sources are
  stopped *before* their rows are given back, kept leases renewed, free sources taken and
  their pollers started (at the source's next due time after the previous holder's last
  contact, spread when many come at once);
- a taken source resumes from the cursor that came with its lease
  (:class:`~sondalog.collect.lease_pg.Taken`), copied into this member's SQLite store,
  where its download reads it;
- a poller checks its lease before the contact and before every batch, and after a batch
  that the ``[postgres]`` sink holds (its buffer is empty) saves the source's cursor with
  the lease: whoever polls next starts where the server's rows stand, and a batch read again
  is stored once (the readings' primary key);
- a member whose turns fail (the server is away) stops its pollers when its leases run out
  (:class:`~sondalog.collect.leases.Holding`): no source is polled by two members at once.

A clean stop gives every lease back at once (the others take them on their next turn); a
``kill -9`` leaves them to run out.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import secrets
import socket
import time
from collections.abc import Callable, Coroutine, Iterable, Sequence
from typing import Any

import psycopg

from sondalog.collect.config import CollectorConfig
from sondalog.collect.delivery import Deliver, Source
from sondalog.collect.lease_pg import LeaseTables, Snapshot, Taken
from sondalog.collect.leases import Holding, plan
from sondalog.collect.store_sqlite import SqliteStore

log = logging.getLogger(__name__)
#: The first contacts of sources taken together are spread over at most this many seconds
#: (and an eighth of the source's interval).
SPREAD = 5.0

#: ``loop(source, delay, once)``: the runner's poller of one source.
Loop = Callable[[Source, float, bool], Coroutine[Any, Any, None]]


class LeaseLost(RuntimeError):
    """This member no longer holds the source (its lease ran out): another one polls it."""


def describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


def member_name() -> str:
    """``HOST:PID:random``: unique among the members, new at every start."""
    return f"{socket.gethostname()}:{os.getpid()}:{secrets.token_hex(3)}"


def share_of(
    config: CollectorConfig,
    store: SqliteStore,
    sources: Sequence[Source],
    confirmed: Callable[[], bool],
    hold: Callable[[set[str]], None] | None = None,
) -> Share | None:
    """The :class:`Share` of a file with a ``[cluster]`` table (None without one)."""
    if config.cluster is None:
        return None
    postgres = config.sinks["postgres"]  # parse_config made sure it is there
    tables = LeaseTables(
        postgres.dsn, member_name(), config.cluster.lease, postgres.connect_timeout
    )
    return Share(tables, store, sources, confirmed, hold)


class Share:
    """Runs the pollers of the sources this member holds (see the module docstring).

    ``confirmed()`` says whether every batch delivered so far is on the PostgreSQL server;
    ``hold(names)`` is told the sources held whenever they change (the alarms watch those).
    """

    def __init__(
        self,
        tables: LeaseTables,
        store: SqliteStore,
        sources: Sequence[Source],
        confirmed: Callable[[], bool],
        hold: Callable[[set[str]], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.tables = tables
        self.store = store
        self.sources = {s.config.name: s for s in sources}
        self.confirmed = confirmed
        self.hold = hold
        self.clock = clock
        self.holding = Holding(tables.lease)
        self.period = tables.lease / 3
        self.tasks: dict[str, asyncio.Task[None]] = {}
        self._held: set[str] = set()
        self._failing = False
        self._joined = False

    # -- the turns ------------------------------------------------------------------------

    async def run(self, loop: Loop, once: bool = False) -> None:
        """Turns until cancelled (``once``: one turn, one contact of each source taken,
        then every lease given back)."""
        try:
            while True:
                started = self.clock()
                await self.turn(loop, once)
                if once:
                    await asyncio.gather(*self.tasks.values(), return_exceptions=True)
                    return
                await asyncio.sleep(max(0.0, self.period - (self.clock() - started)))
        finally:
            await self._stop(list(self.tasks))
            with contextlib.suppress(psycopg.Error, OSError, TimeoutError):
                await asyncio.wait_for(self.tables.leave(), self.tables.lease)
            await self.tables.close()

    async def turn(self, loop: Loop, once: bool = False) -> None:
        """One turn: the plan carried out (within a lease: a server that hangs counts as
        away); the pollers of lapsed leases stopped, those of new ones started."""
        snap: Snapshot | None = None
        taken: list[Taken] = []
        try:
            snap, taken = await asyncio.wait_for(self._carry_out(), self.tables.lease)
        except (psycopg.Error, OSError, TimeoutError) as exc:
            if not self._failing:
                log.warning("cluster: the lease tables are unreachable: %s", describe(exc))
            self._failing = True
            if isinstance(exc, TimeoutError):  # a statement cut short: a new connection
                await self.tables.close()
        else:
            if self._failing:
                log.warning("cluster: the lease tables answer again")
            self._failing = False
        now = self.clock()
        self.holding.lapsed(now)
        held = self.holding.held(now)
        await self._stop([s for s in self.tasks if s not in held])
        if held != self._held and self.hold is not None:
            self.hold(held)
        self._held = held
        if taken:
            log.info("cluster: took %d sources", len(taken))
        # a source taken now, or kept by a turn that came too late for its poller
        idle = [s for s in self.sources if s in held and s not in self.tasks]
        leases = {t.source: t for t in taken}
        for i, name in enumerate(idle):
            self._start(loop, name, leases.get(name), snap, i / len(idle), once)

    async def _carry_out(self) -> tuple[Snapshot, list[Taken]]:
        names = list(self.sources)
        if not self._joined:
            await self.tables.join(names)
            self._joined = True
        snap = await self.tables.snapshot(names)
        todo = plan(self.tables.me, names, snap.leases, snap.members, snap.now)
        if todo.release:
            await self._stop(todo.release)
            self.holding.drop(todo.release)
            await self.tables.release(todo.release)
            log.info("cluster: %d sources handed to other collectors", len(todo.release))
        sent = self.clock()
        kept = await self.tables.renew(todo.keep)
        self.holding.renewed(kept, sent)
        self.holding.drop(set(todo.keep) - kept)
        sent = self.clock()
        taken = await self.tables.take(todo.take, todo.want)
        self.holding.renewed((t.source for t in taken), sent)
        return snap, taken

    def _start(
        self,
        loop: Loop,
        name: str,
        lease: Taken | None,
        snap: Snapshot | None,
        place: float,
        once: bool,
    ) -> None:
        """Start ``name``'s poller (``lease``: it was just taken, resume from its cursor) at
        its next due time, ``place`` (0..1) into the spread of the sources starting now."""
        source = self.sources[name]
        interval = source.config.interval
        due = 0.0
        if lease is not None:
            state = {"cursor": lease.cursor, "logger": lease.logger}
            state = {k: v for k, v in state.items() if v is not None}
            if state:
                self.store.set_state(name, **state)
            if lease.last_contact is not None and snap is not None:
                due = lease.last_contact + interval - snap.now
        spread = min(SPREAD, interval / 8) * place
        delay = 0.0 if once else max(min(max(due, 0.0), interval), spread)
        self.tasks[name] = asyncio.create_task(
            loop(_Leased(source, self), delay, once), name=f"source {name}"
        )

    async def _stop(self, names: Iterable[str]) -> None:
        tasks = [t for n in list(names) if (t := self.tasks.pop(n, None)) is not None]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    # -- what a poller asks ---------------------------------------------------------------

    def check(self, name: str) -> None:
        if not self.holding.holds(name, self.clock()):
            raise LeaseLost(f"source {name} is no longer held by this collector")

    async def save(self, name: str, contact: bool) -> None:
        """Save where ``name`` stands with its lease (the cursor only when the server has
        every batch delivered); raises :class:`LeaseLost` if another member holds it now."""
        row = self.store.source(name) or {}
        cursor = row.get("cursor") if self.confirmed() else None
        if not await self.tables.save(name, cursor, row.get("logger"), contact):
            self.holding.drop([name])
            raise LeaseLost(f"source {name} is held by another collector now")


class _Leased:
    """A source polled under its lease (checked before the contact and every batch)."""

    def __init__(self, inner: Source, share: Share) -> None:
        self.inner = inner
        self.config = inner.config
        self.share = share

    async def poll(self, deliver: Deliver) -> str:
        name, share = self.config.name, self.share
        share.check(name)

        async def fenced(source: str, batch: Any, cursor: str | None, **state: Any) -> None:
            share.check(name)
            await deliver(source, batch, cursor, **state)
            await share.save(name, contact=False)

        summary = await self.inner.poll(fenced)
        await share.save(name, contact=True)
        return summary

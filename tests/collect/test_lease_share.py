"""The turns of a sharing collector (issue 24, ``sondalog.collect.share``) on a real
PostgreSQL: pollers run for the sources held, a cursor saved with the lease is where the
next holder resumes, and a server that goes away stops every poller once the leases run out
(no source polled by two collectors); when it is back the pollers start again."""

from __future__ import annotations

import asyncio
import contextlib
import time
from pathlib import Path

import psycopg
import services

from sondalog.collect.config import SourceConfig
from sondalog.collect.delivery import Deliver, Source
from sondalog.collect.lease_pg import LeaseTables
from sondalog.collect.share import LeaseLost, Share
from sondalog.collect.store_sqlite import SqliteStore

LEASE = 0.9
NAMES = ["one", "two"]


class Counter:
    """A source whose contact delivers no rows and moves its cursor on (``c1``, ``c2``...)."""

    def __init__(self, name: str, store: SqliteStore) -> None:
        self.config = SourceConfig(name=name, url="tcp://127.0.0.1:1", interval=0.1)
        self.store = store
        self.polls: list[float] = []

    async def poll(self, deliver: Deliver) -> str:
        self.polls.append(time.monotonic())
        cursor = self.store.cursor(self.config.name) or "c0"
        await deliver(self.config.name, [], f"c{int(cursor[1:]) + 1}")
        return "ok"


def _collector(tmp: Path, dsn: str, me: str) -> tuple[Share, list[Counter]]:
    store = SqliteStore(tmp / f"{me}.sqlite")
    store.open_sync()
    for name in NAMES:
        store.add_source(name, "tcp://127.0.0.1:1", "logger")
    sources = [Counter(name, store) for name in NAMES]
    tables = LeaseTables(dsn, me, LEASE, connect_timeout=1)
    return Share(tables, store, sources, confirmed=lambda: True), sources


#: Source name -> the store of the collector polling it now.
share_store: dict[str, SqliteStore] = {}


async def _deliver(name: str, batch: object, cursor: str | None, **state: object) -> None:
    share_store[name].commit_chunk(name, [], cursor)


async def _loop(source: Source, delay: float, once: bool) -> None:
    """The runner's poller, short: a contact every 0.1 s; a failure waits for the next."""
    await asyncio.sleep(delay)
    while True:
        with contextlib.suppress(LeaseLost, psycopg.Error):
            await source.poll(_deliver)
        await asyncio.sleep(0.1)


def _cursor(dsn: str, name: str) -> str | None:
    with psycopg.connect(dsn) as db:
        row = db.execute("SELECT cursor FROM collector_leases WHERE source = %s", (name,))
        found = row.fetchone()
    return None if found is None else found[0]


def test_the_cursor_goes_with_the_lease_and_a_lost_server_stops_the_pollers(
    tmp_path: Path, postgres: services.PostgresServer, pg_dsn: str
) -> None:
    first, first_sources = _collector(tmp_path, pg_dsn, "first")
    second, second_sources = _collector(tmp_path, pg_dsn, "second")

    async def run() -> None:
        share_store.update({n: first.store for n in NAMES})
        task = asyncio.create_task(first.run(_loop))
        await asyncio.sleep(1.5)
        assert all(len(s.polls) >= 5 for s in first_sources)
        assert set(first.tasks) == set(NAMES)
        saved = {n: _cursor(pg_dsn, n) for n in NAMES}
        assert all(c is not None and int(c[1:]) >= 5 for c in saved.values()), saved
        postgres.stop()
        try:
            stopped = time.monotonic()
            await asyncio.sleep(LEASE + LEASE / 3 + 0.5)
            assert first.tasks == {}  # the leases ran out: nothing polled
            late = [t for s in first_sources for t in s.polls if t > stopped + LEASE + 0.05]
            assert late == []
        finally:
            postgres.start()
        await asyncio.sleep(2 * LEASE)  # the server is back: the pollers too
        assert set(first.tasks) == set(NAMES)
        task.cancel()  # a clean stop gives the leases back
        await asyncio.gather(task, return_exceptions=True)
        cursors = {n: _cursor(pg_dsn, n) for n in NAMES}
        share_store.update({n: second.store for n in NAMES})
        task = asyncio.create_task(second.run(_loop))
        await asyncio.sleep(0.5)
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        for source in second_sources:  # resumed after the first collector's cursor
            assert source.polls
            assert cursors[source.config.name] is not None
            first_count = int(cursors[source.config.name][1:])  # type: ignore[index]
            now = second.store.cursor(source.config.name)
            assert now is not None and int(now[1:]) > first_count

    asyncio.run(run())

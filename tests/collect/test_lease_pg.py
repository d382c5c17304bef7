"""The lease tables on a real PostgreSQL (issue 24, ``sondalog.collect.lease_pg``), and the
``[cluster]`` table of the collector's file.

Members that take at the same moment never get the same source; a lease that ran out can be
taken by another member, and the old holder can then neither renew it nor save a cursor.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from sondalog.collect.config import load_config
from sondalog.collect.lease_pg import LeaseTables
from sondalog.config import ConfigError

SOURCES = [f"s{i:03}" for i in range(60)]


def test_gathered_takes_split_the_sources(pg_dsn: str) -> None:
    async def run() -> None:
        members = [LeaseTables(pg_dsn, f"m{i}", lease=30) for i in range(4)]
        await members[0].join(SOURCES)
        try:
            takes = await asyncio.gather(*(m.take(SOURCES, 20) for m in members))
            got = [t.source for taken in takes for t in taken]
            assert len(got) == len(set(got)) == 60  # nobody twice, every source once
            assert all(len(taken) <= 20 for taken in takes)
            snap = await members[0].snapshot(SOURCES)
            holders = {s: lease.holder for s, lease in snap.leases.items()}
            for i, taken in enumerate(takes):
                assert all(holders[t.source] == f"m{i}" for t in taken)
        finally:
            for m in members:
                await m.close()

    asyncio.run(run())


def test_an_expired_lease_goes_to_another_and_fences_the_old_holder(pg_dsn: str) -> None:
    async def run() -> None:
        old = LeaseTables(pg_dsn, "old", lease=0.3)
        new = LeaseTables(pg_dsn, "new", lease=30)
        try:
            await old.join(["x", "y"])
            assert [t.source for t in await old.take(["x", "y"], 2)] == ["x", "y"]
            assert await old.save("x", "20260101000000.0", "F01", contact=True)
            assert await new.take(["x", "y"], 2) == []  # held
            await asyncio.sleep(0.4)  # old stalled past its lease
            taken = await new.take(["x"], 1)
            assert [(t.source, t.cursor, t.logger) for t in taken] == [
                ("x", "20260101000000.0", "F01")
            ]
            assert taken[0].last_contact is not None
            assert not await old.save("x", "20260101000099.0", "F01", contact=True)
            assert await old.renew(["x", "y"]) == set()  # y ran out too: not renewed
            assert await new.save("x", None, None, contact=False)  # a cursor kept
            snap = await new.snapshot(["x", "y"])
            assert snap.leases["x"].holder == "new" and snap.leases["x"].expires > snap.now
            await new.leave()
            snap = await old.snapshot(["x", "y"])
            assert snap.leases["x"].holder is None and "new" not in snap.members
        finally:
            await old.close()
            await new.close()

    asyncio.run(run())


def _file(tmp_path: Path, extra: str, postgres: bool = True) -> Path:
    path = tmp_path / "collector.toml"
    sink = '[postgres]\ndsn = "host=db.example dbname=sensors"\n' if postgres else ""
    path.write_text(f'{sink}{extra}\n[[source]]\nurl = "tcp://127.0.0.1:10001"\ninterval = 10\n')
    return path


def test_the_cluster_table(tmp_path: Path) -> None:
    assert load_config(_file(tmp_path, "")).cluster is None
    cluster = load_config(_file(tmp_path, "[cluster]")).cluster
    assert cluster is not None and cluster.lease == 5.0  # half the shortest interval
    cluster = load_config(_file(tmp_path, "[cluster]\nlease = 12")).cluster
    assert cluster is not None and cluster.lease == 12.0
    assert load_config(_file(tmp_path, "[cluster]\nshare = false")).cluster is None


@pytest.mark.parametrize(
    ("extra", "postgres", "says"),
    [
        ("[cluster]", False, ":1: cluster: sharing the sources needs a [postgres] table"),
        ("[cluster]\nlease = 0", True, ":4: cluster.lease: must be a number of seconds"),
        ('[cluster]\nlease = "30s"', True, ":4: cluster.lease: must be a number of seconds"),
        (
            "[cluster]\nleases = 3",
            True,
            ":4: cluster.leases: unknown table or key 'leases' (did you mean lease?",
        ),
    ],
)
def test_cluster_mistakes_name_the_line(
    tmp_path: Path, extra: str, postgres: bool, says: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        load_config(_file(tmp_path, extra, postgres))
    assert says in str(caught.value), str(caught.value)

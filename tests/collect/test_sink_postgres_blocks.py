"""The PostgreSQL sink's blocks of the dashboard (issue 24) against a real server: the blocks
it knows stored are not sent again (``blocks_rule.Written``), and what is stored is still
exactly the blocks of every stored reading."""

from __future__ import annotations

import asyncio
import random
from datetime import datetime, timedelta
from typing import Any

import psycopg
import pytest

from sondalog.collect import blocks_rule, blocks_sql, sink_postgres
from sondalog.collect.model import Reading

T0 = datetime(2026, 1, 1, 5)


def stored_blocks(dsn: str) -> dict[tuple[Any, ...], tuple[Any, ...]]:
    with psycopg.connect(dsn) as c:
        got = c.execute(
            "SELECT logger, size, start, channel, vmin, tmin, vmax, tmax FROM readings_extremes"
        ).fetchall()
    return {tuple(r[:4]): tuple(r[4:]) for r in got}


def blocks_of_rows(dsn: str) -> dict[tuple[Any, ...], tuple[Any, ...]]:
    """The blocks of every stored reading, by the rule (Python), in the key's order."""
    with psycopg.connect(dsn) as c:
        got = c.execute(
            "SELECT logger, channel, time, counter, type, value FROM readings"
            " ORDER BY logger, time, counter, channel"
        ).fetchall()
    readings = [Reading(*r) for r in got]
    return {b[:4]: tuple(b[4:]) for b in blocks_rule.aggregate(readings)}


def batches(seed: int) -> list[list[Reading]]:
    """Two loggers, 3 channels, a row a minute; values from a few (ties) and NULLs; batches
    of 10-70 rows, so that blocks of every size take readings batch after batch."""
    rng = random.Random(seed)
    out: list[list[Reading]] = []
    minute = 0
    while minute < 600:
        n = rng.randrange(10, 70)
        batch = [
            Reading(lg, ch, T0 + timedelta(minutes=m), 0, 1,
                    rng.choice([None, 1.0, 2.0, 2.0, 3.0, rng.uniform(0, 4)]))
            for m in range(minute, minute + n)
            for lg in ("L1", "L2")
            for ch in (1, 2, 3)
        ]  # fmt: skip
        out.append(batch)
        minute += n
    return out


@pytest.mark.parametrize("seed", [1, 2])
def test_blocks_not_sent_again_are_still_those_of_the_rows(
    pg_dsn: str, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    counts = {"made": 0, "sent": 0}
    changing = blocks_rule.Written.changing

    def counted(self: blocks_rule.Written, blocks: Any) -> list[tuple[Any, ...]]:
        blocks = list(blocks)
        sent = changing(self, blocks)
        counts["made"] += len(blocks)
        counts["sent"] += len(sent)
        return sent

    monkeypatch.setattr(blocks_rule.Written, "changing", counted)
    after_batch = blocks_sql.after_batch_postgres

    async def in_key_order(cur: Any, batch: Any, stored: int, blocks: Any = None) -> None:
        assert blocks is None or blocks == sorted(blocks)  # locks taken in one order
        await after_batch(cur, batch, stored, blocks)

    monkeypatch.setattr(blocks_sql, "after_batch_postgres", in_key_order)

    async def run() -> None:
        sink = sink_postgres.create({"dsn": pg_dsn})
        await sink.open()
        for b in batches(seed):
            await sink.write(b)
        await sink.close()

    asyncio.run(run())
    assert counts["sent"] < counts["made"] * 3 // 4  # most coarse blocks left out
    assert stored_blocks(pg_dsn) == blocks_of_rows(pg_dsn)


def test_a_sink_that_connects_again_forgets_what_it_knew(pg_dsn: str) -> None:
    """What it knew was on the server it was connected to: once it connects again (perhaps
    to a server restored from a backup, here one whose blocks were emptied) it sends every
    block again."""
    first = [Reading("L1", 1, T0 + timedelta(minutes=m), 0, 1, 5.0) for m in range(3)]
    later = [Reading("L1", 1, T0 + timedelta(minutes=m), 0, 1, 5.0) for m in range(3, 6)]

    async def run() -> None:
        sink = sink_postgres.create({"dsn": pg_dsn})
        await sink.open()
        await sink.write(first)
        await sink.write(later)  # nothing new for the blocks: not sent
        assert stored_blocks(pg_dsn) == blocks_of_rows(pg_dsn)
        with psycopg.connect(pg_dsn) as c:
            c.execute("DELETE FROM readings_extremes")
        await sink.close()
        await sink.write([Reading("L1", 1, T0 + timedelta(minutes=7), 0, 1, 5.0)])
        await sink.close()

    asyncio.run(run())
    seven = blocks_rule.epoch(T0 + timedelta(minutes=7))
    blocks = stored_blocks(pg_dsn)
    assert {k[1] for k in blocks} == set(blocks_rule.SIZES)
    assert set(blocks.values()) == {(5.0, seven, 5.0, seven)}


def test_a_row_apart_in_a_long_batch_is_stored_whole(pg_dsn: str) -> None:
    """A batch is grouped a piece at a time while the server stores the piece before; a
    row whose readings are pieces apart starts the batch again, grouped at once (not taken
    for a replay: the next batch is copied straight again)."""
    batch = [
        Reading(lg, ch, T0 + timedelta(minutes=m), 0, 1, float(m % 7))
        for m in range(800)
        for lg in ("L1", "L2")
        for ch in (1, 2, 3)
    ]
    batch.append(Reading("L1", 9, T0, 0, 1, -1.0))  # the first row's, 4,800 readings later
    assert len(batch) > 2 * sink_postgres._PIECE

    async def run() -> int:
        sink = sink_postgres.create({"dsn": pg_dsn})
        await sink.open()
        await sink.write(batch)
        assert not sink._replay
        await sink.close()
        return sink.inserted

    assert asyncio.run(run()) == len(batch)
    with psycopg.connect(pg_dsn) as c:
        first = c.execute(
            "SELECT channel, value FROM record_rows WHERE logger = 'L1' AND time = %s", (T0,)
        ).fetchone()
        assert first == ([1, 2, 3, 9], [0.0, 0.0, 0.0, -1.0])
        assert c.execute("SELECT count(*) FROM readings").fetchone() == (len(batch),)
    assert stored_blocks(pg_dsn) == blocks_of_rows(pg_dsn)

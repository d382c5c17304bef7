"""The store merges only the readings that can change the dashboard's block extremes
(:mod:`sondalog.collect.blocks_skip`, issue 24): on random contacts (in time order as a
collector downloads, out of order as messages and replays come, duplicates, NULL values,
ties, failed transactions) it stores exactly the readings and extremes of a store that merges
every reading."""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.collect import blocks_sql
from sondalog.collect.blocks_skip import SentBlocks
from sondalog.collect.model import Reading
from sondalog.collect.store_sqlite import SqliteStore

T0 = datetime(2007, 3, 1, 11, 50, 0)

VALUE = st.none() | st.sampled_from([0.0, 1.0, -1.0, 2.5]) | st.floats(-1e3, 1e3, allow_nan=False)
#: (logger, channel, minute, value): minutes over a few half-hour blocks and two days
ROW = st.tuples(
    st.sampled_from(["000001", "000002"]),
    st.integers(0, 3),
    st.integers(0, 100) | st.sampled_from([1440, 1441, 1470]),
    VALUE,
)
STEP = st.tuples(st.sampled_from(["sorted", "as is"]), st.lists(ROW, max_size=8)) | st.tuples(
    st.just("fail"), st.lists(ROW, min_size=1, max_size=3)
)


def _readings(rows: list[tuple[str, int, int, float | None]]) -> list[Reading]:
    return [Reading(lg, ch, T0 + timedelta(minutes=m), 0, 1, v) for lg, ch, m, v in rows]


def _run(path: Path, steps: list[tuple[str, list[Any]]], skip: bool, behind: float | None) -> None:
    async def main() -> None:
        store = SqliteStore(path).open_sync()
        store.write_behind = behind
        if not skip:
            store.sent = None
        store.add_source("a", "tcp://a:1", "logger")
        for kind, rows in steps:
            if kind == "sorted":
                rows = sorted(rows, key=lambda r: r[2])
            batch = _readings(rows)
            if kind == "fail":  # a transaction that rolls back after merging its blocks
                with contextlib.suppress(sqlite3.IntegrityError), store._transaction(store.db):
                    store._insert(batch)
                    store.db.execute("INSERT INTO sources (name) VALUES ('a')")
                continue
            store.commit_chunk("a", batch, None)
            await asyncio.sleep(0)
        store.close_sync()

    asyncio.run(main())


def _contents(path: Path) -> tuple[Any, ...]:
    with contextlib.closing(sqlite3.connect(path)) as db:
        readings = db.execute("SELECT * FROM readings ORDER BY 1, 2, 3, 4").fetchall()
        blocks = []
        if blocks_sql.has_sqlite(db):
            blocks = db.execute(f"SELECT * FROM {blocks_sql.TABLE} ORDER BY 1, 2, 3, 4").fetchall()
    return readings, blocks


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(steps=st.lists(STEP, max_size=12), behind=st.sampled_from([None, 3600.0]))
def test_skipping_stores_the_extremes_of_merging_every_reading(
    tmp_path_factory: pytest.TempPathFactory, steps: list[tuple[str, list[Any]]], behind: Any
) -> None:
    tmp = tmp_path_factory.mktemp("skip")
    _run(tmp / "every.sqlite", steps, skip=False, behind=behind)
    _run(tmp / "skip.sqlite", steps, skip=True, behind=behind)
    assert _contents(tmp / "skip.sqlite") == _contents(tmp / "every.sqlite")


def test_a_value_inside_its_blocks_extremes_is_not_merged_again() -> None:
    sent = SentBlocks()
    first = _readings([("1", 1, 0, 5.0), ("1", 1, 1, 1.0), ("1", 2, 1, None)])
    assert sent.news(first) == first  # nothing merged yet; then a new minimum
    inside = _readings([("1", 1, 2, 3.0), ("1", 1, 3, 5.0), ("1", 1, 4, 1.0)])
    assert sent.news(inside) == []  # between, or ties at a later time
    news = _readings([("1", 1, 5, 6.0), ("1", 2, 5, None), ("1", 2, 6, 0.5), ("1", 0, 7, 9.0)])
    assert sent.news(news) == news[:3]  # a maximum; a later NULL; a value beats NULL
    assert sent.news(_readings([("1", 1, 40, 3.0)])) != []  # the next half hour
    sent.forget()
    assert sent.news(inside) == inside

"""A record whose older pages live only in the store (issue 24) answers exactly as one with
every row in RAM (record_reference.ListRecordMemory): every read, search, status and change
handed to the store, over random appends (cyclic wraps, linear refusals, the clock set
back; stretches of rows at once, :meth:`RecordMemory.append_many`), clears, images,
resizes, rollbacks of a line and of a failed commit, restarts from the store (only its
newest page read) and restores from a snapshot. The store is a real SQLite file
(:mod:`sondalog.backends.store.ala1_nv`), committed at once or in groups at the end of a
turn (written by the loop or by a writer thread, as a fleet does); the fleet-wide
cache of loaded pages is two pages, so reads go to the file."""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from record_reference import ListRecordMemory
from test_record_pages import STAMPS, _observe

from sondalog.ala1 import record, record_page
from sondalog.ala1.moduleclock import stamps
from sondalog.ala1.record import PAGE, RecordChanges, RecordMemory, load_record
from sondalog.backends.store.ala1_nv import LoggerNvStore, NvDatabase

operations = st.lists(
    st.one_of(
        st.tuples(st.just("append"), st.integers(0, len(STAMPS) - 1), st.integers(1, 40)),
        st.tuples(st.just("burst"), st.integers(0, len(STAMPS) - 1), st.integers(1, 300)),
        st.tuples(st.just("back"), st.integers(0, len(STAMPS) - 1), st.integers(1, 3)),
        st.tuples(st.just("stretch"), st.integers(0, len(STAMPS) - 1), st.integers(1, 150)),
        st.tuples(st.just("mark"), st.just(0), st.just(0)),
        st.tuples(st.just("rollback"), st.just(0), st.just(0)),
        st.tuples(st.just("take"), st.just(0), st.just(0)),
        st.tuples(st.just("failed"), st.just(0), st.just(0)),
        st.tuples(st.just("turn"), st.just(0), st.just(0)),
        st.tuples(st.just("clear"), st.just(0), st.just(0)),
        st.tuples(st.just("image"), st.integers(0, len(STAMPS) - 1), st.integers(1, 150)),
        st.tuples(st.just("resize"), st.integers(300, 20_000), st.booleans()),
        st.tuples(st.just("restart"), st.just(0), st.just(0)),
        st.tuples(st.just("restore"), st.just(0), st.just(0)),
    ),
    max_size=40,
)

FILES = itertools.count()
POINTS = ["2020010100", "20200101001500", "20200101003000.1", "20200101005930", "2021"]


@pytest.fixture
def tiny_cache() -> Iterator[None]:
    """Two pages in the fleet-wide cache of loaded pages: reads go to the file."""
    saved = record_page.LOADED_PAGES
    record_page.LOADED_PAGES = 2
    try:
        yield
    finally:
        record_page.LOADED_PAGES = saved
        record_page._LOADED.clear()


class Turns:
    """An event loop's turn ends when the test says (group commit)."""

    def __init__(self) -> None:
        self.due: list[Callable[[], None]] = []

    def schedule(self, callback: Callable[[], None]) -> None:
        self.due.append(callback)

    def end(self) -> None:
        due, self.due = self.due, []
        for callback in due:
            callback()


def _rows_on_disk(store: LoggerNvStore, memory: Any) -> list[str]:
    """The record as the store holds it (every row read: the reference)."""
    store.database.write([])
    rows, first, _, _ = store.load_record()
    assert first == memory.next_seq - len(memory)
    return rows


@settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    operations,
    st.integers(0, 300),
    st.integers(300, 20_000),
    st.booleans(),
    st.sampled_from(["at once", "in turns", "by a writer thread"]),
    st.sampled_from([0, 1, 2, record.PLAIN_PAGES]),
)
def test_a_record_with_its_pages_in_the_store_answers_as_one_in_ram(
    tmp_path: Path,
    tiny_cache: None,
    ops: list[tuple[str, Any, Any]],
    preload: int,
    capacity: int,
    cyclic: bool,
    commits: str,
    plain_pages: int,
) -> None:
    saved = record.PLAIN_PAGES  # (pages kept plain until the store has them: few or none too)
    record.PLAIN_PAGES = plain_pages
    try:
        _answers_as_one_in_ram(tmp_path, ops, preload, capacity, cyclic, commits)
    finally:
        record.PLAIN_PAGES = saved


def _answers_as_one_in_ram(
    tmp_path: Path,
    ops: list[tuple[str, Any, Any]],
    preload: int,
    capacity: int,
    cyclic: bool,
    commits: str,
) -> None:
    turns = Turns()
    grouped = commits != "at once"
    path = tmp_path / f"fleet-{next(FILES)}.sqlite"  # (tmp_path serves every example)
    background = commits == "by a writer thread"  # (pages then read by a connection of their own)
    database = NvDatabase(path, turns.schedule if grouped else None, background=background)
    store = database.store("F00001")
    try:
        loaded = [f"{STAMPS[i % len(STAMPS)]}.0,1,{i}" for i in range(preload)]
        chars = sum(len(row) + 2 for row in loaded)
        made = RecordChanges(list(enumerate(loaded, 7)), 7, False, False, chars, 7 + preload)
        store.commit({}, None, made)  # (what a run before wrote)
        paged = load_record(store)
        paged.reconfigure(capacity, cyclic)
        plain = ListRecordMemory(list(loaded), 7, capacity, cyclic)
        marks: list[tuple[Any, Any]] = []

        def commit() -> None:
            changes = paged.take_changes()
            assert changes == plain.take_changes()
            if changes is not None:
                if grouped:
                    store.commit_scheduled(changes, 0.0)
                else:
                    store.commit({}, None, changes)
            marks.clear()  # (no mark survives a commit)

        for kind, a, b in ops:
            if kind in ("append", "burst", "back"):
                count = b if kind != "back" else 1
                for n in range(count):
                    stamp = STAMPS[(a + n // 3) % len(STAMPS)] if kind == "burst" else STAMPS[a]
                    body = f"1,{n}" + ",12.5" * (n % 4)
                    assert paged.append(stamp, body) == plain.append(stamp, body)
            elif kind == "stretch":  # a stretch of sampling instants at once (series path)
                stamps = [STAMPS[(a + n) % len(STAMPS)] for n in range(b)]  # (may wrap: back)
                bodies = [
                    f"1,{n}" + ",12.5" * (n % 4) + "," * (b % 7 * 60 * (n == 3)) for n in range(b)
                ]
                paged.append_many(stamps, bodies)
                for stamp, body in zip(stamps, bodies, strict=True):
                    plain.append(stamp, body)
            elif kind == "mark":
                marks.append((paged.mark(), plain.mark()))
            elif kind == "rollback" and marks:
                mark_paged, mark_plain = marks.pop()
                paged.rollback(mark_paged)
                plain.rollback(mark_plain)
                marks.clear()
            elif kind == "take":
                commit()
            elif kind == "failed":  # a line whose commit failed: nothing reached the store
                mark_paged, mark_plain = paged.mark(), plain.mark()
                paged.append(STAMPS[-1], "1,lost")
                plain.append(STAMPS[-1], "1,lost")
                assert paged.take_changes() == plain.take_changes()
                paged.rollback(mark_paged)
                plain.rollback(mark_plain)
                marks.clear()
            elif kind == "turn":
                turns.end()
            elif kind == "clear":
                paged.clear()
                plain.clear()
            elif kind == "image":
                rows = [f"{STAMPS[(a + i) % len(STAMPS)]}.{i % 10},2,image {i}" for i in range(b)]
                paged.load_rows(list(rows))
                plain.load_rows(list(rows))
            elif kind == "resize":
                paged.reconfigure(a, b)
                plain.reconfigure(a, b)
            elif kind in ("restart", "restore"):
                commit()
                turns.end()
                settings_ = (paged.capacity, paged.cyclic)
                flags = (paged.wrapped, paged.refused)
                first = paged.next_seq - len(paged)
                if kind == "restart":  # only the newest page read (record_size agrees)
                    assert store.load_paged_record()[0].known_chars == paged.chars
                    paged = load_record(store)
                    paged.reconfigure(*settings_)
                    flags = (paged.wrapped, paged.refused)  # (as stored by the last commit)
                else:  # a snapshot's sealed rows, the store as the source (Preloaded)
                    sealed = dataclasses.replace(paged.sealed(), source=store)
                    paged = RecordMemory(sealed, first, *settings_, *flags)
                plain = ListRecordMemory(plain.rows(), first, *settings_, *flags)
            assert _observe(paged, POINTS) == _observe(plain, POINTS)
        commit()
        turns.end()
        assert _observe(paged, POINTS) == _observe(plain, POINTS)
        assert _rows_on_disk(store, paged) == plain.rows()
    finally:
        database.close()


def test_a_month_of_rows_keeps_only_its_newest_in_ram(tmp_path: Path, tiny_cache: None) -> None:
    """43,200 rows of a cyclic record: RAM holds no page but the newest rows (and the one
    the oldest row is in while rows are dropped from it); a start reads one page."""
    database = NvDatabase(tmp_path / "fleet.sqlite")
    store = database.store("F1")
    try:
        memory = load_record(store)
        memory.reconfigure(1_000_000, True)
        for minute in range(43_200):
            day, rest = divmod(minute, 1440)
            stamp = f"202001{day + 1:02}{rest // 60:02}{rest % 60:02}00"
            memory.append(stamp, f"1,12.{minute % 7},12.{minute % 5},11.9,{minute % 60}")
            if minute % 60 == 59:
                store.commit({}, None, memory.take_changes())
        assert memory.wrapped and memory.take_changes() is None
        held = [page for page in memory._pages if page is not None]
        assert len(held) <= 1
        assert len(memory._tail) < PAGE + 16
        again = load_record(store)
        again.reconfigure(1_000_000, True)
        assert again._pages.count(None) == len(again._pages) > 400
        assert again.status() == memory.status() == "0,1.00,FULL"
        assert again.chars == memory.chars
        assert again.rows() == memory.rows()  # (pages read in one go)
        assert again.rows(0, 3) == memory.rows(0, 3)
        assert again.rows(len(memory) - 2) == memory.rows(len(memory) - 2)
        point = "20200115"
        assert again.position_at_or_after(point) == memory.position_at_or_after(point)
    finally:
        database.close()


def test_pages_the_store_is_handed_are_not_compressed(tmp_path: Path) -> None:
    """With the store as the source, the pages sealed since the last commit keep their rows
    plain (the store has them at the commit, then RAM lets go of them: compressing them was
    work for nothing, issue 24 sixth round), up to PLAIN_PAGES; a snapshot's are compressed."""
    database = NvDatabase(tmp_path / "plain.sqlite")
    store = database.store("F00001")
    try:
        memory = load_record(store)
        memory.reconfigure(10**7, True)
        start = 1_577_836_800  # (2020-01-01, a row a minute)
        minutes = list(range(start, start + 120_000, 60))
        memory.append_many(stamps(minutes), [f"1,{n}" for n in range(2000)])
        pages = memory._pages
        assert len(pages) > 2 and all(page is not None and page.rows for page in pages)
        assert all(page.data for page in memory.sealed().pages if page is not None)
        store.commit({}, None, memory.take_changes())
        assert memory.take_changes() is None
        assert all(page is None for page in memory._pages)  # (let go: the store has them)
        assert memory.rows(0, 2) == ["20200101000000.0,1,0", "20200101000100.0,1,1"]
        more = stamps(list(range(start + 200_000, start + 200_000 + PAGE * 67 * 60, 60)))
        memory.append_many(more, ["1,x"] * len(more))  # (64 pages plain, then compressed)
        kept = [page for page in memory._pages if page is not None]
        assert sum(page.rows is not None for page in kept) == record.PLAIN_PAGES
        assert all(page.data for page in kept if page.rows is None)  # (beyond: compressed)
    finally:
        database.close()

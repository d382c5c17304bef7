"""The record's rows sealed into compressed pages (issue 24) answer exactly as one string a
row did (record_reference.ListRecordMemory): every read, search, status and change handed
to the store, over random operations (appends on one stamp, clock set back, wraps,
rollbacks, images, clears, compaction, a restore from a snapshot's sealed rows)."""

from __future__ import annotations

from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st
from record_reference import ListRecordMemory

from sondalog.ala1 import record
from sondalog.ala1.record import PAGE, RecordMemory

STAMPS = [f"2020010100{m:02}{s:02}" for m in range(60) for s in (0, 30)]

operations = st.lists(
    st.one_of(
        st.tuples(st.just("append"), st.integers(0, len(STAMPS) - 1), st.integers(1, 40)),
        st.tuples(st.just("burst"), st.integers(0, len(STAMPS) - 1), st.integers(1, 200)),
        st.tuples(st.just("back"), st.integers(0, len(STAMPS) - 1), st.integers(1, 3)),
        st.tuples(st.just("mark"), st.just(0), st.just(0)),
        st.tuples(st.just("rollback"), st.just(0), st.just(0)),
        st.tuples(st.just("take"), st.just(0), st.just(0)),
        st.tuples(st.just("clear"), st.just(0), st.just(0)),
        st.tuples(st.just("image"), st.integers(0, len(STAMPS) - 1), st.integers(1, 150)),
        st.tuples(st.just("resize"), st.integers(300, 20_000), st.booleans()),
        st.tuples(st.just("copy"), st.just(0), st.just(0)),
    ),
    max_size=40,
)


def _observe(memory: Any, points: list[str]) -> tuple[Any, ...]:
    n = len(memory)
    return (
        n,
        memory.status(),
        memory.chars,
        memory.next_seq,
        memory.rows(),
        memory.rows(n // 3, 7),
        memory.rows(n, 5),
        tuple(memory.position_at_or_after(p) for p in points),
        tuple(memory.position_after(p) for p in points),
    )


@settings(max_examples=150, deadline=None)
@given(
    operations,
    st.integers(0, 300),
    st.integers(300, 20_000),
    st.booleans(),
)
def test_paged_rows_answer_as_a_list_of_rows(
    ops: list[tuple[str, Any, Any]], preload: int, capacity: int, cyclic: bool
) -> None:
    loaded = [f"{STAMPS[i % len(STAMPS)]}.0,1,{i}" for i in range(preload)]
    paged = RecordMemory(list(loaded), 7, capacity, cyclic)
    plain = ListRecordMemory(list(loaded), 7, capacity, cyclic)
    marks: list[tuple[Any, Any]] = []
    points = ["2020010100", "20200101001500", "20200101003000.1", "20200101005930", "2021"]
    for kind, a, b in ops:
        if kind in ("append", "burst", "back"):
            count = b if kind != "back" else 1
            for n in range(count):
                stamp = STAMPS[(a + n // 3) % len(STAMPS)] if kind == "burst" else STAMPS[a]
                body = f"1,{n}" + ",12.5" * (n % 4)
                assert paged.append(stamp, body) == plain.append(stamp, body)
        elif kind == "mark":
            marks.append((paged.mark(), plain.mark()))
        elif kind == "rollback" and marks:
            mark_paged, mark_plain = marks.pop()
            paged.rollback(mark_paged)
            plain.rollback(mark_plain)
            marks.clear()  # (a mark lives for one line: none survives a rollback)
        elif kind == "take":
            assert paged.take_changes() == plain.take_changes()
            marks.clear()  # (and none survives a commit)
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
        elif kind == "copy":  # a restore: a new record from a snapshot's sealed rows
            assert paged.take_changes() == plain.take_changes()
            marks.clear()
            first, flags = paged.next_seq - len(paged), (paged.wrapped, paged.refused)
            settings_ = (paged.capacity, paged.cyclic)
            paged = RecordMemory(paged.sealed(), first, *settings_, *flags)
            plain = ListRecordMemory(plain.rows(), first, *settings_, *flags)
        assert _observe(paged, points) == _observe(plain, points)
    assert paged.take_changes() == plain.take_changes()
    assert _observe(paged, points) == _observe(plain, points)


def test_old_rows_are_sealed_into_compressed_pages() -> None:
    """A month of 1-minute rows: all but the newest rows are in pages, far smaller than the
    rows' text; reading from the start and the end still gives the rows."""
    memory = RecordMemory([], 0, 10**7, True)
    for minute in range(43_200):
        day, rest = divmod(minute, 1440)
        stamp = f"202001{day + 1:02}{rest // 60:02}{rest % 60:02}00"
        memory.append(stamp, f"1,12.{minute % 7},12.{minute % 5},11.9,{minute % 60}")
        if minute % 500 == 0:
            memory.take_changes()
    assert len(memory) == 43_200
    assert len(memory._tail) < PAGE + record.KEEP
    text = sum(len(row) for row in memory.rows())
    packed = sum(len(page.data) + len(page.ends) * page.ends.itemsize for page in memory._pages)
    assert packed * 3 < text
    assert memory.rows(0, 1) == ["20200101000000.0,1,12.0,12.0,11.9,0"]
    assert memory.rows(43_199)[0].startswith("20200130235900.0,")
    assert memory.position_at_or_after("20200115") == 14 * 1440


def test_a_wrapping_record_compacts_its_pages_as_the_list_did() -> None:
    """A small cyclic record written 20,000 times: dropped pages leave RAM (compaction),
    and every change handed to the store is the list's."""
    paged = RecordMemory([], 0, 2_000, True)
    plain = ListRecordMemory([], 0, 2_000, True)
    for n in range(20_000):
        stamp = STAMPS[(n // 7) % len(STAMPS)]
        assert paged.append(stamp, f"1,{n}") == plain.append(stamp, f"1,{n}")
        if n % 9 == 0:
            assert paged.take_changes() == plain.take_changes()
            assert paged.rows() == plain.rows() and paged.status() == plain.status()
    assert paged.take_changes() == plain.take_changes()
    assert len(paged._pages) * PAGE < 8_192  # not every row ever written
    assert paged.position_after(STAMPS[100]) == plain.position_after(STAMPS[100])

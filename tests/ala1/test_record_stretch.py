"""A stretch of rows stored at once (:meth:`RecordMemory.append_many`, issue 24) leaves the
record memory exactly as :meth:`RecordMemory.append` of each row in turn does: the rows, the
characters, the oldest row kept and the newest (the erase and read pointers), the wrapped
and refused flags, the status and every change handed to the store. Random stretches of
ascending seconds, of a second repeated from the newest row or of seconds going back (the
clock set back), rows of a few lengths (so that a cyclic record's drops end exactly at a
row's end), rows larger than the record; cyclic and linear records, small and larger than a
page, in RAM or with their pages in a store (the pages let go are loaded back while their
rows are dropped). (Checked by breaking it on purpose: not setting the wrapped flag,
dropping one row too many or too few, counting every first row ``.0``, taking a row larger
than a cyclic record, each fails it.)"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_record_pages import _observe

from sondalog.ala1.moduleclock import stamp
from sondalog.ala1.record import RecordChanges, RecordMemory, load_record
from sondalog.backends.store.ala1_nv import NvDatabase

T = 1_167_609_600  # 2007-01-01 00:00:00 in module seconds
FILES = itertools.count()
#: Body lengths: mostly alike (drops then end exactly at a row's end), some long.
LENGTHS = [6, 6, 6, 6, 5, 7, 13, 40, 300]
#: The characters of a row of the common length, with its CR LF: ``YYYYMMDDhhmmss.c,1,n,``
#: and six digits.
ROW = 16 + 5 + 6 + 2

stretch = st.tuples(
    st.sampled_from(["up", "up", "up", "same", "back"]),
    st.integers(1, 30),  # seconds between rows
    st.one_of(  # rows alike, or alike but one
        st.builds(lambda n, length: [length] * n, st.integers(1, 150), st.sampled_from(LENGTHS)),
        st.builds(
            lambda n, at, odd: [odd if k == at % n else 6 for k in range(n)],
            st.integers(1, 150),
            st.integers(0, 150),
            st.sampled_from(LENGTHS),
        ),
        st.lists(st.sampled_from(LENGTHS), min_size=1, max_size=150),
    ),
)


def _state(memory: RecordMemory) -> tuple[Any, ...]:
    """What is observable of the memory, and its pointers and flags."""
    first = memory.next_seq - len(memory)
    return (*_observe(memory, ["2007", "20070101003000"]), first, memory.wrapped, memory.refused)


def _both(
    many: RecordMemory, single: RecordMemory, stamps: list[str], bodies: list[str]
) -> RecordChanges | None:
    """The stretch at once to ``many``, row by row to ``single``: the same state and the
    same changes for the store (returned)."""
    many.append_many(stamps, bodies)
    for s, body in zip(stamps, bodies, strict=True):
        single.append(s, body)
    assert _state(many) == _state(single)
    changes = many.take_changes()
    assert changes == single.take_changes()
    return changes


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.lists(stretch, min_size=1, max_size=6),
    st.one_of(  # (whole rows of the common length: a drop ends exactly at a row's end)
        st.sampled_from([24, 64, 200, 1000, 4096]),
        st.integers(20, 8000),
        st.integers(1, 200).map(lambda rows: rows * ROW),
    ),
    st.booleans(),
    st.booleans(),
)
def test_a_stretch_at_once_stores_what_rows_one_by_one_store(
    tmp_path: Path,
    stretches: list[tuple[str, int, list[int]]],
    capacity: int,
    cyclic: bool,
    paged: bool,
) -> None:
    database = NvDatabase(tmp_path / f"s{next(FILES)}.sqlite") if paged else None
    store = database.store("S1") if database is not None else None
    try:
        many = load_record(store) if store is not None else RecordMemory([], 0, 0, True)
        many.reconfigure(capacity, cyclic)
        single = RecordMemory([], 0, capacity, cyclic)
        t = T
        for n, (kind, step, lengths) in enumerate(stretches):
            if kind == "back":  # (the clock set back: the path of rows one by one)
                seconds = [t - step * k for k in range(len(lengths))]
            else:  # ascending, the first in the newest row's second ("same": counted .1)
                seconds = [t + step * (k + (kind == "up")) for k in range(len(lengths))]
            t = max(seconds)
            stamps = [stamp(s) for s in seconds]
            bodies = [f"1,{n}," + "7" * length for length in lengths]
            changes = _both(many, single, stamps, bodies)
            if store is not None and changes is not None:
                store.commit({}, None, changes)  # (its pages let go: dropped from the store)
        assert many.rows() == single.rows()
    finally:
        if database is not None:
            database.close()


@pytest.mark.parametrize("alike", [False, True])
def test_a_stretch_that_wraps_a_paged_record_drops_pages_let_go(
    tmp_path: Path, alike: bool
) -> None:
    """A cyclic record over a store, full: a stretch drops rows of pages RAM let go (loaded
    back for their rows' ends) and of pages it holds, as rows one by one do; rows alike in
    a record of whole rows: the drops end exactly at a row's end."""
    database = NvDatabase(tmp_path / "wrap.sqlite")
    store = database.store("S2")
    capacity = 200 * ROW if alike else 6000
    try:
        many = load_record(store)
        many.reconfigure(capacity, True)
        single = RecordMemory([], 0, capacity, True)
        for day in range(8):  # (a stretch of 100 rows drops rows of the pages)
            seconds = [T + day * 86400 + 60 * k for k in range(100 if alike else 400)]
            stamps = [stamp(s) for s in seconds]
            if alike:
                bodies = [f"1,{day},{k % 10:06}" for k in range(len(seconds))]
            else:
                bodies = [f"1,{day},{k % 9}" + ",5" * (k % 3) for k in range(len(seconds))]
            changes = _both(many, single, stamps, bodies)
            assert changes is not None
            store.commit({}, None, changes)
        assert many.paged and None in many._pages  # (pages were let go)
        assert many.status() == "0,1.00,FULL"
    finally:
        database.close()


@settings(max_examples=60, deadline=None)
@given(
    st.integers(2500, 6000),
    st.lists(st.lists(st.integers(0, 20), min_size=60, max_size=120), min_size=3, max_size=5),
)
def test_stretches_that_drop_rows_of_pages(capacity: int, stretches: list[list[int]]) -> None:
    """Cyclic records of some 100 to 250 rows and stretches of 60 to 120 rows of any
    length: every stretch after the first few drops rows sealed into pages, the last one
    dropped anywhere in its page."""
    many = RecordMemory([], 0, capacity, True)
    single = RecordMemory([], 0, capacity, True)
    t = T
    for n, lengths in enumerate(stretches):
        stamps = [stamp(t + 60 * k) for k in range(1, len(lengths) + 1)]
        t += 60 * len(lengths)
        bodies = [f"1,{n}," + "3" * length for length in lengths]
        _both(many, single, stamps, bodies)

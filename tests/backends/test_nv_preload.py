"""A fleet's memory read at once for its start (issue 24, backends/store/preload.py): every
store answers inside :meth:`NvDatabase.preloaded` exactly as it answers from the tables,
before and after commits made meanwhile (a new logger's clock, a repaired value, rows, a
table file), on a real SQLite file."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.ala1.record import PAGE, RecordChanges
from sondalog.backends.store.ala1_nv import LoggerNvStore, NvDatabase

FILES = itertools.count()

rows = st.integers(0, 3 * PAGE + 5)
logger_memory = st.fixed_dictionaries(
    {
        "params": st.dictionaries(
            st.sampled_from(["a", "b", "c 1 x"]), st.text("xyz09", max_size=3)
        ),
        "offset": st.none() | st.floats(-1e9, 1e9),
        "seen": st.none() | st.floats(0, 2e9),
        "rows": rows,
        "head": rows,
        "sized": st.booleans(),
        "files": st.dictionaries(st.sampled_from(["list", "data"]), st.binary(max_size=8)),
    }
)
commit = st.tuples(
    st.integers(0, 3),
    st.dictionaries(st.sampled_from(["a", "b", "d"]), st.none() | st.just("v"), max_size=2),
    st.none() | st.floats(-1e6, 1e6),
    st.integers(0, PAGE + 3),  # rows appended
    st.none() | st.sampled_from(["list", "data"]),  # a table file written
)


def _record(count: int, head: int, sized: bool, start: int = 0) -> RecordChanges:
    made = [(seq, f"2020{seq:010},1,{seq}") for seq in range(start, start + count)]
    end = start + count
    size = {"chars": 7 * (end - min(head, end)), "end": end} if sized else {}
    return RecordChanges(made, min(head, end), False, False, **size)


def _answers(store: LoggerNvStore) -> tuple[Any, ...]:
    sealed, first, wrapped, refused = store.load_paged_record()
    return (
        store.load(),
        store.last_seen(),
        store.load_files(),
        (sealed.pages, sealed.tail, sealed.head, sealed.known_chars, first, wrapped, refused),
    )


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(logger_memory, min_size=1, max_size=4), st.lists(commit, max_size=6))
def test_preloaded_stores_answer_as_the_tables_do(
    tmp_path: Path, memories: list[dict[str, Any]], commits: list[tuple[Any, ...]]
) -> None:
    path = tmp_path / f"fleet{next(FILES)}.sqlite"
    database = NvDatabase(path)
    names = [f"L{n}" for n in range(4)]  # (some never written)
    ends = dict.fromkeys(names, 0)
    for name, memory in zip(names, memories, strict=False):
        record = (
            _record(memory["rows"], memory["head"], memory["sized"]) if memory["rows"] else None
        )
        database.write([(name, (memory["params"], memory["offset"], record, memory["seen"]))])
        ends[name] = memory["rows"]
        for area, data in memory["files"].items():
            database.store(name).write_file(area, data)
    plain = [_answers(database.store(name)) for name in names]
    with database.batch(), database.preloaded(names):
        assert [_answers(database.store(name)) for name in names] == plain
        for number, changes, offset, added, area in commits:
            name = names[number]
            store = database.store(name)
            record = _record(added, 0, True, ends[name]) if added else None
            ends[name] += added
            if number % 2:
                store.commit(changes, offset, record, seen=float(number))
            elif record is not None:
                store.commit_scheduled(record, float(number))
            if area is not None:
                store.write_file(area, bytes([number]))
            preloaded = _answers(store)
            database.preload, saved = None, database.preload
            try:
                assert preloaded == _answers(store)
            finally:
                database.preload = saved
    database.close()

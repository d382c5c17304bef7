"""write_state (a restore's durable write) leaves exactly the snapshot's record on disk,
whatever the record holds now: overlapping, disjoint, longer, shorter, within a page and
across pages (``record_pages``), on a disk whose head page still holds rows a cyclic record
dropped; and the restored record goes on growing from where the snapshot ended."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.ala1.record import RecordChanges, RecordMemory
from sondalog.app.control_snapshot import read_state, write_state
from sondalog.backends.store.ala1_nv import NvDatabase
from sondalog.backends.store.record_pages import PAGE_ROWS, drop_below, write_record

_RECORD = st.tuples(st.integers(1, 400), st.lists(st.sampled_from('abc,\\"é'), max_size=300))


@settings(
    max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(_RECORD, _RECORD, st.integers(-150, 150), st.integers(0, 4), st.integers(0, PAGE_ROWS + 6))
def test_the_disk_holds_the_snapshots_record_after_a_restore(
    tmp_path_factory: pytest.TempPathFactory,
    wanted: tuple[int, list[str]],
    now: tuple[int, list[str]],
    shift: int,
    rewrite: int,
    dropped: int,
) -> None:
    database = NvDatabase(tmp_path_factory.mktemp("nv") / "nv.sqlite")
    store, conn = database.store("L1"), database.conn

    def record(first: int, rows: list[str], dropped: int = 0) -> RecordMemory:
        """``rows`` on disk from ``first`` as a cyclic record leaves them after dropping
        ``dropped`` rows (its head page may still hold them) and the engine's copy."""
        start = max(0, first - dropped)
        write_record(conn, "L1", start, ["gone"] * (first - start) + rows)
        store.commit({}, None, RecordChanges([], first, True, False))
        return RecordMemory(list(rows), first, 10**6, True)

    def on_disk() -> list[tuple[int, str]]:
        return conn.execute(
            "SELECT seq, row FROM record WHERE logger = 'L1' ORDER BY seq"
        ).fetchall()

    try:
        rows = [f"{i}:{c * (i % 5)}" for i, c in enumerate(wanted[1])]
        state = read_state(store, record(wanted[0], rows))
        # now: from near the snapshot's first row (``shift`` 0: anywhere), the same rows
        # where both hold one but every 4th (rewritten since; ``rewrite`` 4: none)
        now_first = max(0, wanted[0] + shift) if shift else now[0]
        kept = dict(enumerate(rows, wanted[0]))
        now_rows = [
            kept[seq] if seq in kept and seq % 4 != rewrite else f"{seq}:{c}"
            for seq, c in enumerate(now[1], now_first)
        ]
        write_state(store, state, record(now_first, now_rows, dropped))
        assert on_disk() == list(enumerate(rows, wanted[0]))
        assert store.load_record()[:2] == (rows, wanted[0])
        # the engine over the restored memory writes its next rows after the snapshot's
        following = [(wanted[0] + len(rows) + i, f"new {i}") for i in range(PAGE_ROWS + 2)]
        expected = [*enumerate(rows, wanted[0]), *following][1 if rows else 0 :]  # 1 dropped
        store.commit({}, None, RecordChanges(following, expected[0][0], True, False))
        assert on_disk() == expected
        assert store.load_record()[:2] == ([r for _, r in expected], expected[0][0])
    finally:
        database.close()


def test_whole_pages_below_the_head_go_and_the_head_page_stays_as_it_is() -> None:
    database = NvDatabase(":memory:")
    conn = database.conn
    write_record(conn, "L1", 5, [str(i) for i in range(5, 5 + 3 * PAGE_ROWS)])
    drop_below(conn, "L1", PAGE_ROWS + 3)
    pages = conn.execute("SELECT page, first, count FROM record_page ORDER BY page").fetchall()
    assert pages == [
        (1, PAGE_ROWS, PAGE_ROWS),
        (2, 2 * PAGE_ROWS, PAGE_ROWS),
        (3, 3 * PAGE_ROWS, 5),
    ]
    database.close()


def test_a_restore_after_a_short_test_writes_the_pages_that_differ_only() -> None:
    """A cyclic record of 1,000 rows moved on by 40 (40 dropped, 40 new): the restore
    writes the two pages they are in and deletes the one the new rows began."""
    database = NvDatabase(":memory:")
    store, conn = database.store("L1"), database.conn
    rows = [f"row {i}" for i in range(1000)]
    write_record(conn, "L1", 0, rows)
    state = read_state(store, RecordMemory(rows, 0, 10**6, True))
    new = [(1000 + i, f"new {i}") for i in range(40)]
    store.commit({}, None, RecordChanges(new, 40, True, False))
    conn.execute("CREATE TEMP TABLE written (page INTEGER, how TEXT)")
    for event, row in (("INSERT", "new"), ("DELETE", "old")):
        conn.execute(
            f"CREATE TEMP TRIGGER on_{event} AFTER {event} ON main.record_page "
            f"BEGIN INSERT INTO written VALUES ({row}.page, '{event}'); END"
        )
    write_state(store, state, RecordMemory([*rows[40:], *(r for _, r in new)], 40, 10**6, True))
    written = conn.execute("SELECT page, how FROM written ORDER BY page").fetchall()
    assert written == [(0, "INSERT"), (15, "INSERT"), (16, "DELETE")]
    assert store.load_record()[:2] == (rows, 0)
    database.close()


def test_one_snapshot_restored_again_and_again_in_a_fleets_file() -> None:
    """A snapshot keeps its pages once made (``StoredState.pages``): restored after records
    that share no row with it, share some, or are empty, the disk holds its record each
    time; the other logger of the file is never touched."""
    database = NvDatabase(":memory:")
    conn = database.conn
    mine, other = database.store("L1"), database.store("L2")
    others = [f"L2 row {i}" for i in range(300)]
    write_record(conn, "L2", 7, others)
    rows = [f"row {i}" for i in range(500)]
    write_record(conn, "L1", 100, rows)
    state = read_state(mine, RecordMemory(list(rows), 100, 10**6, True))
    for first, count in ((5000, 700), (300, 500), (0, 0), (9000, 3), (100, 500), (40, 90)):
        now = [f"now {i}" for i in range(count)]
        write_record(conn, "L1", first, now)
        write_state(mine, state, RecordMemory(now, first, 10**6, True))
        assert mine.load_record()[:2] == (rows, 100)
        assert other.load_record()[:2] == (others, 7)
    assert state.pages.every is not None  # (made once, used again)
    database.close()

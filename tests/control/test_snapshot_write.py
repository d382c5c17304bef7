"""write_state (a restore's durable write) leaves exactly the snapshot's record on disk,
whatever the record holds now: overlapping, disjoint, longer, shorter, long runs (written
through one json_each statement) and short ones (a statement per row)."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.ala1.record import RecordMemory
from sondalog.app.control_snapshot import read_state, write_state
from sondalog.backends.store.ala1_nv import NvDatabase

_RECORD = st.tuples(st.integers(1, 400), st.lists(st.sampled_from('abc,\\"é'), max_size=300))


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(_RECORD, _RECORD, st.integers(0, 3))
def test_the_disk_holds_the_snapshots_record_after_a_restore(
    tmp_path_factory: pytest.TempPathFactory,
    wanted: tuple[int, list[str]],
    now: tuple[int, list[str]],
    rewrite: int,
) -> None:
    database = NvDatabase(tmp_path_factory.mktemp("nv") / "nv.sqlite")
    store, conn = database.store("L1"), database.conn

    def record(first: int, rows: list[str]) -> RecordMemory:
        conn.execute("DELETE FROM record WHERE logger = 'L1'")
        conn.executemany(
            "INSERT INTO record (logger, seq, row) VALUES ('L1', ?, ?)",
            list(enumerate(rows, first)),
        )
        return RecordMemory(list(rows), first, 10**6, True)

    try:
        rows = [f"{i}:{c * (i % 5)}" for i, c in enumerate(wanted[1])]
        state = read_state(store, record(wanted[0], rows))
        pairs = zip(now[1], [*rows, *now[1]], strict=False)  # some rows as the snapshot's
        now_rows = [f"{i}:{c}" if i % 4 != rewrite else row for i, (c, row) in enumerate(pairs)]
        write_state(store, state, record(now[0], now_rows))
        on_disk = conn.execute(
            "SELECT seq, row FROM record WHERE logger = 'L1' ORDER BY seq"
        ).fetchall()
        assert on_disk == list(enumerate(rows, wanted[0]))
    finally:
        database.close()

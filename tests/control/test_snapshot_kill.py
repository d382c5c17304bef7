"""kill -9 in the middle of restores: the memory on disk is one snapshot or the other,
never a mix (issue 23: a restore is one durable transaction, ``write_state``).

A child process restores two snapshots of one logger in turn, as fast as it can, on a real
file (WAL, ``synchronous=FULL``); it is killed with SIGKILL at moments spread over its
writes. Each time, the file opened again holds exactly snapshot A or snapshot B: the
parameters, the meta, the files and every record row of one of them.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from sondalog.ala1.record import RecordMemory
from sondalog.app.control_snapshot import StoredState
from sondalog.backends.store.ala1_nv import SqliteNvStore

ROWS = 3000


def snapshot(name: str, first: int) -> StoredState:
    """A logger's memory: parameters, meta and a file named after ``name``, a record of
    :data:`ROWS` rows from ``first`` (A's and B's overlap in part, pages differ)."""
    rows = tuple(
        f"{name} row {seq}" if seq % 3 else f"row {seq}" for seq in range(first, first + ROWS)
    )
    meta = (("clock_offset", f"{first}.5"), ("record_head", str(first)), ("record_wrapped", "1"))
    return StoredState(
        (("channel 1 name", name), (f"{name} only", "1")),
        meta,
        (("list", name.encode()),),
        first,
        rows,
    )


A, B = snapshot("A", 1000), snapshot("B", 2000)

CHILD = """
import sys
from sondalog.ala1.record import RecordMemory
from sondalog.app.control_snapshot import write_state
from sondalog.backends.store.ala1_nv import SqliteNvStore
sys.path.insert(0, sys.argv[2])
from test_snapshot_kill import A, B
store = SqliteNvStore(sys.argv[1])
now = RecordMemory([], 0, 10**6, True)
for state in (A, B) * 10_000:
    write_state(store, state, now)
    now = RecordMemory(list(state.record), state.first_seq, 10**6, True)
    print(state.params[0][1], flush=True)
"""


def on_disk(path: Path) -> StoredState:
    store = SqliteNvStore(path)
    try:
        params = store.load()[0]
        rows, first, _, _ = store.load_record()
        meta = store.conn.execute("SELECT key, value FROM meta ORDER BY key").fetchall()
        files = store.load_files()
    finally:
        store.close()
    return StoredState(
        tuple(sorted(params.items())),
        tuple(meta),
        tuple(sorted(files.items())),
        first,
        tuple(rows),
    )


def sorted_state(state: StoredState) -> StoredState:
    return StoredState(
        tuple(sorted(state.params)),
        tuple(sorted(state.meta)),
        tuple(sorted(state.files)),
        state.first_seq,
        state.record,
    )


def test_a_kill_during_restores_leaves_one_snapshot_whole(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    seen = {"A": 0, "B": 0}
    for round_ in range(6):
        path = tmp_path / f"ala1-{round_}.sqlite"
        child = subprocess.Popen(
            [sys.executable, "-c", CHILD, str(path), str(Path(__file__).parent)],
            stdout=subprocess.PIPE,
            env=env,
        )
        assert child.stdout is not None
        for _ in range(2 + round_ * 3):  # restores done before the kill: more each round
            assert child.stdout.readline() in (b"A\n", b"B\n")
        time.sleep(0.001 * round_)  # (and within a restore at a moment that varies)
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
        child.stdout.close()
        found = on_disk(path)
        assert found in (sorted_state(A), sorted_state(B)), "a mix of both snapshots"
        seen[dict(found.params)["channel 1 name"]] += 1
        # the engine's record over it goes on where the snapshot's ended
        RecordMemory(list(found.record), found.first_seq, 10**6, True)
    assert seen["A"] and seen["B"]

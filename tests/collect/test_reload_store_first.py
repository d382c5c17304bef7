"""A reload whose store write fails changes nothing (issue 24, sixth round's mend).

``Collector.reload`` registers the new and changed sources in the store before it stops or
starts any task: a store that refuses (here a real SQLite file held by another connection's
exclusive lock past the busy timeout) leaves the running sources, their tasks and the
configuration exactly as they were, and the same reload taken once the lock is gone applies
in full. Before the mend the removed source was already stopped when the store failed.
"""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3
from pathlib import Path

import pytest

from sondalog.collect.config import load_config
from sondalog.collect.runner import Collector


def _write(path: Path, sources: dict[str, float]) -> None:
    path.write_text(
        '[sqlite]\npath = "s.sqlite"\n\n[web]\nenabled = false\n\n'
        + "".join(
            f'[[source]]\nname = "{name}"\nurl = "tcp://127.0.0.1:9"\ninterval = {every}\n\n'
            for name, every in sources.items()
        )
    )


def test_a_reload_the_store_refuses_changes_nothing(tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    _write(path, {"a": 600, "b": 600, "c": 600})

    async def main() -> None:
        collector = Collector(load_config(path))
        stop = asyncio.Event()
        run = asyncio.create_task(collector.run(stop))
        for _ in range(100):
            if len(collector._tasks) == 3:
                break
            await asyncio.sleep(0.01)
        assert sorted(collector._tasks) == ["a", "b", "c"]
        tasks, sources, config = dict(collector._tasks), list(collector.sources), collector.config
        collector.store.db.execute("PRAGMA busy_timeout=50")
        _write(path, {"a": 600, "b": 30, "d": 600})  # b changed, c removed, d added
        new = load_config(path)
        locker = sqlite3.connect(tmp_path / "s.sqlite", isolation_level=None)
        try:
            locker.execute("BEGIN EXCLUSIVE")
            with pytest.raises(sqlite3.OperationalError, match="locked"):
                await collector.reload(new)
            await asyncio.sleep(0)  # a cancel, had one been made, would land now
            assert collector._tasks == tasks
            assert not any(t.done() for t in tasks.values())
            assert collector.sources == sources and collector.config is config
        finally:
            locker.execute("ROLLBACK")
            locker.close()
        assert await collector.reload(new) == (1, 1, 1)
        assert sorted(collector._tasks) == ["a", "b", "d"]
        assert collector._tasks["a"] is tasks["a"]  # unchanged: not restarted
        assert tasks["b"].cancelled() and tasks["c"].cancelled()
        stop.set()
        with contextlib.suppress(asyncio.CancelledError):
            await asyncio.wait_for(run, 10)

    asyncio.run(main())

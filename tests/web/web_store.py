"""Fixtures for the dashboard: a real SQLite store with the collector's DDL, a real uvicorn."""

from __future__ import annotations

import asyncio
import sqlite3
import threading
from collections.abc import Iterable, Iterator
from datetime import datetime, timedelta
from pathlib import Path

from starlette.applications import Starlette

from sondalog.collect.schema import SQLITE_DDL
from sondalog.web import serve

Row = tuple[str, int, str, int, int, float | None, str | None, str | None, str | None]

CHANNELS_DDL = """CREATE TABLE IF NOT EXISTS channels (
    logger TEXT NOT NULL, channel INTEGER NOT NULL, name TEXT, unit TEXT, type INTEGER,
    PRIMARY KEY (logger, channel))"""


def make_store(path: Path, *, with_channels: bool = True) -> Path:
    conn = sqlite3.connect(path)
    conn.executescript(SQLITE_DDL)
    conn.execute("PRAGMA journal_mode=WAL")
    if with_channels:
        conn.execute(CHANNELS_DDL)
    conn.commit()
    conn.close()
    return path


def insert(path: Path, rows: Iterable[Row]) -> int:
    """Insert readings the way the collector does (idempotent)."""
    conn = sqlite3.connect(path)
    with conn:
        cur = conn.executemany(
            "INSERT OR IGNORE INTO readings (logger, channel, time, counter, type, value, "
            "text, name, unit) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
            rows,
        )
        n = cur.rowcount
    conn.close()
    return n


def execute(path: Path, sql: str, params: Iterable[object] = ()) -> None:
    conn = sqlite3.connect(path)
    with conn:
        conn.execute(sql, tuple(params))
    conn.close()


def series_rows(
    logger: str,
    channel: int,
    start: str,
    step_s: int,
    count: int,
    *,
    name: str,
    unit: str,
    value: float = 0.0,
    slope: float = 0.1,
) -> Iterator[Row]:
    t0 = datetime.fromisoformat(start)
    for i in range(count):
        t = (t0 + timedelta(seconds=i * step_s)).strftime("%Y-%m-%dT%H:%M:%S")
        yield (logger, channel, t, 0, 1, value + slope * i, None, name, unit)


class Running:
    """A dashboard served by uvicorn in a thread's own event loop."""

    def __init__(self, app: Starlette, **kw: object) -> None:
        self.app = app
        self.port = 0
        self.error: BaseException | None = None
        self._ready = threading.Event()
        self._loop = asyncio.new_event_loop()
        self._task: asyncio.Task[None] | None = None
        self._kw = kw
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        if not self._ready.wait(10):
            raise RuntimeError("the dashboard did not start")
        if self.error is not None:
            raise self.error

    def _listening(self, host: str, port: int) -> None:
        self.port = port
        self._ready.set()

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        self._task = self._loop.create_task(
            serve(self.app, "127.0.0.1", 0, on_listen=self._listening, **self._kw)  # type: ignore[arg-type]
        )
        try:
            self._loop.run_until_complete(self._task)
        except asyncio.CancelledError:
            pass
        except BaseException as exc:
            self.error = exc
        finally:
            self._ready.set()
            self._loop.close()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def stop(self) -> None:
        assert self._task is not None
        self._loop.call_soon_threadsafe(self._task.cancel)
        self._thread.join(10)
        assert not self._thread.is_alive()

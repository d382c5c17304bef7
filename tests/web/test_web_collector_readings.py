"""Which store the collector's dashboard reads its readings from (``[web] readings``, issue 24),
and the per-block extremes the wiring makes there before serving.

A real collector (``run_collector``, its source unreachable: no contact needed) with its
dashboard on a free port: with ``[sqlite] readings = false`` and a ``[postgres]`` sink the
dashboard shows the readings written to the server (the file has none), and the server got
the per-block extremes (``readings_extremes``, filled in the background from the rows stored
before); with the file as store of record the file got them.
"""

from __future__ import annotations

import asyncio
import json
import sqlite3
import threading
import urllib.request
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import psycopg
import pytest

from sondalog.app.collector import WebUnavailable, run_collector
from sondalog.collect import sink_postgres
from sondalog.collect.config import load_config, parse_config
from sondalog.collect.model import Reading
from sondalog.collect.runner import Collector
from sondalog.collect.store_sqlite import SqliteStore
from sondalog.collect.web_config import readings_on_server
from sondalog.config import ConfigError, loads


def _file(folder: Path, extra: str) -> Path:
    path = folder / "collector.toml"
    path.write_text(
        '[[source]]\nname = "far"\nurl = "tcp://127.0.0.1:9"\ninterval = 3600\n'
        '[web]\nlisten = "127.0.0.1:0"\n' + extra
    )
    return path


def _serve(config: Path) -> tuple[str, asyncio.Event, threading.Thread, list[BaseException]]:
    """The collector with its dashboard in a thread's loop; its URL once it listens."""
    urls: list[str] = []
    errors: list[BaseException] = []
    ready = threading.Event()
    holder: dict[str, Any] = {}

    def run() -> None:
        async def main() -> None:
            holder["stop"] = stop = asyncio.Event()
            holder["loop"] = asyncio.get_running_loop()
            collector = Collector(load_config(config))
            collector.open()
            try:
                await run_collector(
                    collector,
                    stop,
                    on_web=lambda h, p: (urls.append(f"http://{h}:{p}"), ready.set()),
                )
            finally:
                await collector.close()

        try:
            asyncio.run(main())
        except BaseException as exc:
            errors.append(exc)
        finally:
            ready.set()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    assert ready.wait(120)
    if errors:
        raise errors[0]
    loop, stop = holder["loop"], holder["stop"]

    class Stopper(asyncio.Event):
        def set(self) -> None:
            loop.call_soon_threadsafe(stop.set)

    return urls[0], Stopper(), thread, errors


def _series(url: str, query: str = "") -> dict[str, Any]:
    with urllib.request.urlopen(f"{url}/api/loggers/L/series{query}", timeout=30) as resp:
        data: dict[str, Any] = json.loads(resp.read())
        return data


async def _write(dsn: str, n: int) -> None:
    sink = sink_postgres.create({"dsn": dsn, "timescaledb": "off"})
    await sink.open()
    t0 = datetime(2026, 3, 1)
    await sink.write(
        [Reading("L", 1, t0 + timedelta(minutes=i), 0, 1, float(i % 17)) for i in range(n)]
    )
    await sink.close()


def test_readings_setting_chooses_the_store() -> None:
    def web(text: str) -> Any:
        root = loads('[[source]]\nurl = "tcp://127.0.0.1:9"\n' + text, Path("c.toml"))
        return parse_config(root).web

    assert web("").readings == "auto"
    with pytest.raises(ConfigError, match=r"c.toml:4: web.readings"):
        web('[web]\nreadings = "mysql"\n')
    auto, pg, file = (
        web(""),
        web('[web]\nreadings = "postgres"\n'),
        web('[web]\nreadings = "sqlite"\n'),
    )
    assert readings_on_server(auto, file_keeps_readings=False, has_postgres=True)
    assert not readings_on_server(auto, file_keeps_readings=True, has_postgres=True)
    assert not readings_on_server(auto, file_keeps_readings=False, has_postgres=False)
    assert readings_on_server(pg, file_keeps_readings=True, has_postgres=True)
    assert not readings_on_server(file, file_keeps_readings=False, has_postgres=True)
    with pytest.raises(ValueError, match="needs a \\[postgres\\] sink"):
        readings_on_server(pg, file_keeps_readings=True, has_postgres=False)


def test_collector_dashboard_reads_the_server_of_record(tmp_path: Path, pg_dsn: str) -> None:
    asyncio.run(_write(pg_dsn, 5000))  # more than 2,000 points: downsampled
    config = _file(tmp_path, f'[sqlite]\nreadings = false\n[postgres]\ndsn = "{pg_dsn}"\n')
    url, stop, thread, _ = _serve(config)
    try:
        for _ in range(100):  # the wiring fills the blocks in the background
            with psycopg.connect(pg_dsn) as conn:
                if conn.execute(
                    "SELECT to_regclass('readings_extremes_todo') IS NOT NULL "
                    "AND NOT EXISTS (SELECT FROM readings_extremes_todo)"
                ).fetchone()[0]:
                    break
            threading.Event().wait(0.1)
        data = _series(url, "?from=2026-03-01&to=2026-03-05")
        assert data["downsampled"] and data["last"] == "2026-03-04T11:19:00"
        (s,) = data["series"]
        assert (min(v for v in s["v"] if v is not None), max(s["v"] or [0])) == (0.0, 16.0)
        with psycopg.connect(pg_dsn) as conn:
            n = conn.execute("SELECT count(*) FROM readings_extremes").fetchone()[0]
        assert n > 0
    finally:
        stop.set()
        thread.join(30)
    file = sqlite3.connect(tmp_path / "collector.sqlite")
    assert file.execute("SELECT count(*) FROM readings").fetchone()[0] == 0


def test_collector_dashboard_on_its_file_makes_the_blocks_there(tmp_path: Path) -> None:
    config = _file(tmp_path, "")  # in [web]
    url, stop, thread, _ = _serve(config)
    try:
        file = sqlite3.connect(tmp_path / "collector.sqlite")
        for _ in range(100):  # the filler makes the tables (nothing to fill in a new file)
            names = {r[0] for r in file.execute("SELECT name FROM sqlite_master")}
            if {"readings_extremes", "readings_extremes_todo"} <= names:
                break
            threading.Event().wait(0.1)
        sink = SqliteStore(tmp_path / "collector.sqlite").open_sync()  # as the collector writes
        asyncio.run(sink.write([Reading("L", 1, datetime(2026, 3, 1), 0, 1, 4.5)]))
        sink.close_sync()
        got = file.execute("SELECT size, vmax FROM readings_extremes ORDER BY size").fetchall()
        assert got == [(1800, 4.5), (7200, 4.5), (21600, 4.5), (86400, 4.5)]
        file.close()
        assert _series(url)["series"][0]["v"] == [4.5]
    finally:
        stop.set()
        thread.join(30)


def test_postgres_readings_without_a_postgres_sink_is_refused(tmp_path: Path) -> None:
    config = _file(tmp_path, 'readings = "postgres"\n')  # in [web]
    with pytest.raises(WebUnavailable, match=r"web\.readings: readings = 'postgres' needs"):
        _serve(config)


def test_blocks_false_is_refused(tmp_path: Path) -> None:
    """``[web] blocks = false`` (the switch while the blocks cost ingest twice its time) is
    refused with the reason: they are always kept now."""
    config = _file(tmp_path, "blocks = false\n")  # in [web]
    with pytest.raises(ConfigError, match=r"blocks.*always kept now"):
        load_config(config)

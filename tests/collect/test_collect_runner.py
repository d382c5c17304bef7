"""The runner in-process: a sink that is down (the buffer), another logger at a source's URL."""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3
import time
from collections.abc import Sequence
from pathlib import Path

from served_logger import configure, sampling_logger

from sondalog.collect.buffer import DiskBuffer
from sondalog.collect.config import CollectorConfig, SourceConfig
from sondalog.collect.model import Reading, SinkUnavailable
from sondalog.collect.runner import Collector
from sondalog.collect.sinks import register_sink


class Outage:
    """A sink whose server is unreachable until ``up`` is set."""

    name = "outage"

    def __init__(self) -> None:
        self.up = False
        self.keys: set[tuple[str, str, int, int]] = set()

    async def open(self) -> None:
        if not self.up:
            raise SinkUnavailable("connection refused")

    async def write(self, batch: Sequence[Reading]) -> None:
        if not self.up:
            raise SinkUnavailable("connection refused")
        self.keys |= {r.key for r in batch}

    async def close(self) -> None:
        pass


def test_batches_wait_while_a_sink_is_down(tmp_path: Path) -> None:
    sink = Outage()
    register_sink("outage", lambda config: sink, lambda table: table.keys(()))
    with sampling_logger(tmp_path, 50) as served:
        configure(served)
        time.sleep(0.3)
        config = CollectorConfig(
            tmp_path / "c.toml",
            tmp_path / "store.sqlite",
            True,
            tmp_path / "buffer.sqlite",
            (SourceConfig("station", served.url, interval=1),),
            {"outage": {}},
        )
        asyncio.run(Collector(config).run(asyncio.Event(), once=True))
        with contextlib.closing(DiskBuffer(config.buffer)) as buffer:
            assert buffer.count("outage") > 0
        assert not sink.keys
        served.ask("write channel sampling period 000000 000000")
        sink.up = True
        asyncio.run(Collector(config).run(asyncio.Event(), once=True))
    with contextlib.closing(sqlite3.connect(config.store)) as db:
        stored = {
            (logger, time_, counter, channel)
            for logger, time_, counter, channel in db.execute(
                "SELECT logger, time, counter, channel FROM readings"
            )
        }
    assert stored and sink.keys == stored
    with contextlib.closing(DiskBuffer(config.buffer)) as buffer:
        assert buffer.count("outage") == 0


def test_another_logger_at_a_sources_url_is_read_from_its_oldest_row(tmp_path: Path) -> None:
    from sondalog.collect.store_sqlite import SqliteStore

    store = SqliteStore(tmp_path / "store.sqlite").open_sync()
    store.add_source("station", "tcp://old:1", "logger")
    store.set_state("station", logger="999999", cursor="20990101000000.0")
    store.close_sync()
    with sampling_logger(tmp_path, 50) as served:
        configure(served)
        time.sleep(0.2)
        served.ask("write channel sampling period 000000 000000")
        rows = served.record()
        config = CollectorConfig(
            tmp_path / "c.toml",
            tmp_path / "store.sqlite",
            True,
            tmp_path / "buffer.sqlite",
            (SourceConfig("station", served.url, interval=1),),
            {},
        )
        asyncio.run(Collector(config).run(asyncio.Event(), once=True))
    store.open_sync()
    assert store.cursor("station") == rows[-1].split(",")[0]
    assert store.source("station")["logger"] == "000001"  # type: ignore[index]
    kinds = [event[2] for event in store.events("station")]
    assert kinds == ["logger", "download"]
    assert "000001 instead of 999999" in store.events("station")[0][3]
    store.close_sync()

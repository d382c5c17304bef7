"""One round trip a contact (issue 24): :meth:`Download.contact` pipelines the identification,
the caller's commands and the first chunk; what it reads is what the step by step path reads.

A real served logger gets random configurations (channel count, names with and without units,
analog and supply channels, rows of ``write channel value`` with any row type and channel
list, text rows), the record is read from a random cursor in chunks of a random size, with the
channel count of the last contact right, wrong or unknown: the rows, gaps, channels, answers
and the collector's readings of both paths are the same.
"""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from served_logger import Served, sampling_logger

from sondalog.client import Ala1Client
from sondalog.client.ala1_codec import MAX_LINE
from sondalog.client.download import _HEAD, Download, _chained, _names
from sondalog.collect.config import CollectorConfig, SourceConfig
from sondalog.collect.readings import rows_to_readings
from sondalog.collect.runner import Collector

EXTRA = ("read record status", "read channel type read channel format")


@pytest.fixture(scope="module")
def logger(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    with sampling_logger(tmp_path_factory.mktemp("pipeline"), 50) as served:
        served.ask("write date 20070301000000", "write channel sampling period 000000")
        yield served


def configure(
    served: Served, channels: list[tuple[str, str | None, bool]], rows: list[tuple[str, int, Any]]
) -> None:
    """The logger with ``channels`` (name, unit, analog) and ``rows`` written (a text row, or
    ``write channel value`` of a row type and channel list) on an empty record."""
    count = len(channels)
    setup = ["write record status clear", f"write channel max number {count}"]
    setup.append(f"write output 1 value {len(rows) % 2}")  # the supply divider on or off
    for n, (name, unit, analog) in enumerate(channels, start=1):
        label = name if unit is None else f"{name}[{unit}]"
        setup.append(f"write channel {n} name/{label}/")
        setup.append(
            f"write channel {n} type 3 write channel {n} address 16 "
            f"write channel {n} switch output 0"
            if analog
            else f"write channel {n} type 1"
        )
    for kind, row_type, body in rows:
        if kind == "text":
            setup.append(f"write text {row_type}/{body}/")
        else:
            listed = " ".join(str(c) for c in sorted(set(body)) if c <= count)
            setup.append(f"write channel {listed} value {row_type}".replace("  ", " "))
    served.ask(*setup)


async def stepwise(url: str, after: str | None, per: int) -> tuple[Any, ...]:
    """The path before pipelining: identify, each command, then the chunks."""
    async with await Ala1Client.connect(url) as client:
        download = Download(client, after=after, rows_per_chunk=per, max_rows=per)
        info = await download.identify()
        answers = [await client.command(command) for command in EXTRA]
        chunks = [chunk async for chunk in download.chunks()]
    return info, answers, chunks


async def pipelined(url: str, after: str | None, per: int, guess: int | None) -> tuple[Any, ...]:
    async with await Ala1Client.connect(url) as client:
        download = Download(client, after=after, rows_per_chunk=per, max_rows=per)
        info, answers = await download.contact(EXTRA, guess)
        chunks = [chunk async for chunk in download.chunks()]
    return info, answers, chunks


NAME = st.text("ABCxyz _-", min_size=1, max_size=6).filter(lambda s: s.strip() == s)
CHANNEL = st.tuples(NAME, st.none() | st.sampled_from(["V", "m", "°C", ""]), st.booleans())
ROW = st.one_of(
    st.tuples(st.just("value"), st.integers(2, 9), st.lists(st.integers(1, 6), max_size=3)),
    st.tuples(st.just("text"), st.integers(3, 9), st.text("abc ,.", min_size=1, max_size=8)),
)


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    channels=st.lists(CHANNEL, min_size=1, max_size=12),  # names in up to three lines
    rows=st.lists(ROW, max_size=25),
    cursor=st.none() | st.integers(0, 30),
    per=st.sampled_from([1, 2, 3, 7, 20]),
    guess=st.sampled_from(["right", "wrong", "unknown"]),
)
def test_pipelined_contact_reads_what_the_step_by_step_path_reads(
    logger: Served,
    channels: list[tuple[str, str | None, bool]],
    rows: list[tuple[str, int, Any]],
    cursor: int | None,
    per: int,
    guess: str,
) -> None:
    count = len(channels)
    configure(logger, channels, rows)
    record = logger.record()
    after = None
    if cursor is not None and record:
        after = record[min(cursor, len(record) - 1)].split(",")[0]
    last = {"right": count, "wrong": count % 12 + 1, "unknown": None}[guess]
    old_info, old_answers, old_chunks = asyncio.run(stepwise(logger.url, after, per))
    new_info, new_answers, new_chunks = asyncio.run(pipelined(logger.url, after, per, last))
    assert (new_info.snumber, new_info.channels) == (old_info.snumber, old_info.channels)
    assert [a.lines for a in new_answers] == [a.lines for a in old_answers]
    assert [(c.rows, c.gap) for c in new_chunks] == [(c.rows, c.gap) for c in old_chunks]
    readings = [rows_to_readings(c.rows, new_info.snumber, new_info.channels) for c in new_chunks]
    assert readings == [
        rows_to_readings(c.rows, old_info.snumber, old_info.channels) for c in old_chunks
    ]
    expected = [r for r in record if after is None or r.split(",")[0] > after]
    assert [row.key for c in new_chunks for row in c.rows] == [r.split(",")[0] for r in expected]


def test_a_collector_contact_is_one_round_trip(
    logger: Served, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The second contact of a source (its channel count known) writes to the line once."""
    logger.ask(
        "write record status clear",
        "write channel max number 3 write output 1 value 1",
        "write channel 1 type 1 write channel 2 type 1 write channel 3 type 1",
        "write channel value",
    )
    writes: list[str] = []
    original, exchange = Ala1Client.pipeline, Ala1Client.exchange

    async def counted(self: Ala1Client, requests: Any, **kw: Any) -> Any:
        requests = list(requests)
        writes.append(str(requests[0]))
        return await original(self, requests, **kw)

    async def exchanged(self: Ala1Client, payload: bytes, parse: Any, **kw: Any) -> Any:
        writes.append(payload.decode())
        return await exchange(self, payload, parse, **kw)

    monkeypatch.setattr(Ala1Client, "pipeline", counted)
    monkeypatch.setattr(Ala1Client, "exchange", exchanged)
    config = CollectorConfig(
        tmp_path / "c.toml",
        tmp_path / "store.sqlite",
        True,
        tmp_path / "buffer.sqlite",
        # the configuration check (issue 22) reads the tree: its own round trips, off here
        (SourceConfig("station", logger.url, interval=1, config_every=0),),
        {},
    )
    collector = Collector(config)

    async def two_contacts() -> None:
        collector.open()
        source = collector.sources[0]
        await source.poll(collector.deliver)
        async with await Ala1Client.connect(logger.url) as client:
            assert (await client.command("write channel value")).ok
        writes.clear()
        await source.poll(collector.deliver)
        await collector.close()

    asyncio.run(two_contacts())
    assert len(writes) == 1, writes
    collector.store.open_sync()
    stored = collector.store.db.execute("SELECT count(*) FROM readings").fetchone()[0]
    assert stored == 6, (logger.record(), collector.store.events())  # both rows, three channels
    collector.store.close_sync()


@given(st.from_regex(r"\d{14}", fullmatch=True) | st.text("0123456789 +-٣", max_size=16))
def test_a_stamp_is_read_as_strptime_reads_it(text: str) -> None:
    from datetime import datetime

    from sondalog.client.records import stamp

    try:
        expected: object = datetime.strptime(text, "%Y%m%d%H%M%S")
    except ValueError:
        expected = ValueError
    try:
        got: object = stamp(text)
    except ValueError:
        got = ValueError
    assert got == expected


def test_the_identification_is_chained_into_lines_the_logger_keeps() -> None:
    """Every chained line fits the 120 characters a module keeps (§3.4.1) and the lines hold
    the identification's commands in order, the head alone in the first."""
    for guess in range(100):
        lines = _chained(guess)
        assert all(len(line) <= MAX_LINE for line in lines)
        assert lines[0] == " ".join(_HEAD)
        assert " ".join(lines[1:]) == " ".join(_names(guess))

"""A contact's prefetched chunk taken without the async generator (issue 24, sixth round):
``Download.prefetched_step`` then ``Download.chunks`` read the same chunks, in the same order,
and leave the download in the same state as the generator of before alone, on random
configurations of a real served logger (cursors, chunk sizes, rows that need more chunks)."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from served_logger import Served, sampling_logger
from test_contact_pipeline import CHANNEL, ROW, configure

from sondalog.client import Ala1Client
from sondalog.client.download import Chunk, Download
from sondalog.client.visit import visit


@pytest.fixture(scope="module")
def logger(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    with sampling_logger(tmp_path_factory.mktemp("step"), 50) as served:
        served.ask("write date 20070301000000", "write channel sampling period 000000")
        yield served


async def _before(self: Download) -> AsyncIterator[Chunk]:
    """``Download.chunks`` as it was before the sixth round (the frozen reference)."""
    while True:
        wanted = self.rows_per_chunk
        prefetched, self._prefetched = self._prefetched, None
        if prefetched is not None and prefetched[0] == self._command(wanted):
            _, response, elapsed = prefetched
            chunk, sent = self._parse(response, wanted, 0)
            self._adapt(chunk, elapsed)
        else:
            chunk, sent = await self._chunk(wanted)
        self.include_after = False
        if chunk.rows:
            self.after = chunk.cursor
        if chunk.rows or chunk.gap:
            yield chunk
        if sent < wanted:
            return


def _state(download: Download) -> tuple[Any, ...]:
    return (
        download.after,
        download.include_after,
        download.rows_per_chunk,
        download.record_empty,
        download._prefetched,
    )


async def _read(url: str, after: str | None, per: int, include: bool, now: bool) -> Any:
    """The chunks of one contact: the way the collector takes them now, or the old way."""
    async with await Ala1Client.connect(url) as client:
        download = Download(
            client, after=after, rows_per_chunk=per, max_rows=per, include_after=include
        )
        download.clock = iter(range(0, 10_000, 3)).__next__  # the same elapsed times
        await visit(download, None)
        chunks: list[Chunk] = []
        if now:
            step = download.prefetched_step()
            if step is not None and (step[0].rows or step[0].gap):
                chunks.append(step[0])
            if step is None or step[1]:
                chunks += [chunk async for chunk in download.chunks()]
        else:
            chunks = [chunk async for chunk in _before(download)]
    return [(c.rows, c.gap, c.bytes, c.rereads) for c in chunks], _state(download)


@settings(
    max_examples=20,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    channels=st.lists(CHANNEL, min_size=1, max_size=6),
    rows=st.lists(ROW, max_size=25),
    cursor=st.none() | st.integers(0, 30),
    per=st.sampled_from([1, 2, 3, 7, 20]),
    include=st.booleans(),
)
def test_the_prefetched_step_reads_what_the_generator_read(
    logger: Served,
    channels: list[tuple[str, str | None, bool]],
    rows: list[tuple[str, int, Any]],
    cursor: int | None,
    per: int,
    include: bool,
) -> None:
    configure(logger, channels, rows)
    record = logger.record()
    after = None
    if cursor is not None and record:
        after = record[min(cursor, len(record) - 1)].split(",")[0]
    include = include and after is not None
    old = asyncio.run(_read(logger.url, after, per, include, now=False))
    new = asyncio.run(_read(logger.url, after, per, include, now=True))
    assert new == old
    keys = [row.key for chunk in new[0] for row in chunk[0]]
    assert keys == sorted(keys) and len(keys) == len(set(keys))

"""``keep_open``: a logger source's connection kept between contacts (issue 24).

Against a real served logger (``sondalog logger serve``, sampling), directly or through a
real TCP peer (:mod:`tcp_peer`) that closes, resets, stalls or takes one connection at a
time: the readings stored are those of the source without ``keep_open``, a contact on a
connection that died since is made again on a fresh one (nothing lost, nothing delivered
twice), and what the collector holds is closed when the source goes.
"""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from served_logger import Served, configure, sampling_logger
from tcp_peer import Peer

from sondalog.collect.config import CollectorConfig, SourceConfig
from sondalog.collect.keep_open import KeptConnections
from sondalog.collect.runner import Collector
from sondalog.collect.sources import LoggerSource
from sondalog.collect.store_sqlite import SqliteStore


@pytest.fixture(scope="module")
def logger(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    """A logger sampling two channels, twenty rows a second."""
    with sampling_logger(tmp_path_factory.mktemp("keep"), 20) as served:
        configure(served)
        time.sleep(0.5)
        yield served


class Station:
    """One source with its own store; every reading it delivers is counted."""

    def __init__(
        self, tmp: Path, name: str, url: str, kept: KeptConnections | None, timeout: float = 5
    ) -> None:
        self.store = SqliteStore(tmp / f"{name}.sqlite").open_sync()
        self.store.add_source(name, url, "logger")
        config = SourceConfig(name, url, keep_open=kept is not None, timeout=timeout)
        self.source = LoggerSource(config, self.store, kept)
        self.delivered: list[tuple[str, str, int, int]] = []

    async def deliver(self, name: str, batch: Any, cursor: str | None, **state: Any) -> None:
        self.delivered.extend(r.key for r in batch)
        self.store.commit_chunk(name, batch, cursor, **state)

    async def contact(self) -> str:
        return await self.source.poll(self.deliver)

    def readings(self) -> list[tuple[Any, ...]]:
        return self.store.db.execute(
            "SELECT logger, channel, time, counter, type, value, text, name, unit, utc "
            "FROM readings ORDER BY logger, time, counter, channel"
        ).fetchall()

    def twice(self) -> list[tuple[str, str, int, int]]:
        seen: set[tuple[str, str, int, int]] = set()
        return [k for k in self.delivered if k in seen or seen.add(k)]  # type: ignore[func-returns-value]


async def reference(tmp: Path, url: str, upto: tuple[Any, ...] | None) -> list[tuple[Any, ...]]:
    """What a source without ``keep_open`` stores of the logger's record, up to ``upto``
    (a reading's row: its time, counter)."""
    plain = Station(tmp, f"ref{time.monotonic_ns()}", url, None)
    await plain.contact()
    rows = plain.readings()
    plain.store.close_sync()
    if upto is None:
        return rows
    return [r for r in rows if (r[2], r[3]) <= (upto[2], upto[3])]


def test_readings_are_those_without_keep_open(logger: Served, tmp_path: Path) -> None:
    async def main() -> None:
        kept = KeptConnections()
        keeping = Station(tmp_path, "keeping", logger.url, kept)
        plain = Station(tmp_path, "plain", logger.url, None)
        for _ in range(6):
            await keeping.contact()
            await plain.contact()
            await asyncio.sleep(0.15)
        assert (kept.opened, kept.reused, len(kept)) == (1, 5, 1) and plain.source.kept is None
        rows = keeping.readings()
        assert len(rows) > 40 and not keeping.twice()
        last = rows[-1]
        assert rows == await reference(tmp_path, logger.url, last)
        await keeping.contact()
        await plain.contact()  # both up to the same newest row now (a second's rows apart)
        both = min(_final(keeping), _final(plain))
        upto = [r for r in keeping.readings() if (r[2], r[3]) <= (both[2], both[3])]
        assert upto == [r for r in plain.readings() if (r[2], r[3]) <= (both[2], both[3])]
        kept.close()
        assert len(kept) == 0

    asyncio.run(main())


def _final(station: Station) -> tuple[Any, ...]:
    rows = station.readings()
    assert rows
    return rows[-1]


def test_a_peer_that_closes_between_contacts(logger: Served, tmp_path: Path) -> None:
    async def main() -> None:
        peer = await Peer(logger.port).start()
        kept = KeptConnections()
        station = Station(tmp_path, "s", peer.url, kept)
        await station.contact()
        peer.close_all()
        await asyncio.sleep(0.2)
        await station.contact()  # found closed when taken: a fresh connection
        await asyncio.sleep(0.2)
        await station.contact()
        assert (peer.accepted, kept.opened, kept.reused) == (2, 2, 1)
        assert not station.twice()
        assert station.readings() == await reference(tmp_path, logger.url, _final(station))
        kept.close()
        await peer.stop()

    asyncio.run(main())


@pytest.mark.parametrize("at", [0, 30, 400, 2500])
def test_a_peer_that_resets_in_the_middle_of_an_answer(
    logger: Served, tmp_path: Path, at: int
) -> None:
    async def main() -> None:
        peer = await Peer(logger.port).start()
        kept = KeptConnections()
        station = Station(tmp_path, f"s{at}", peer.url, kept)
        await station.contact()
        await asyncio.sleep(0.6)  # rows for more than one chunk
        assert peer.arm("reset", at) == 1
        # the reset: the contact once more on a fresh connection (or, when it comes in the
        # configuration's read, which a contact survives, the next contact connects afresh)
        assert (await station.contact()).startswith("logger ")
        assert (await station.contact()).startswith("logger ")
        assert (peer.accepted, kept.opened) == (2, 2)
        assert not station.twice()
        assert station.readings() == await reference(tmp_path, logger.url, _final(station))
        kept.close()
        await peer.stop()

    asyncio.run(main())


def test_a_peer_that_takes_one_connection(logger: Served, tmp_path: Path) -> None:
    """A GPRS modem's TCP server takes one connection at a time: a kept one is reused, and
    a new one is made only after the peer closed the old one."""

    async def main() -> None:
        peer = await Peer(logger.port, one_at_a_time=True).start()
        kept = KeptConnections()
        station = Station(tmp_path, "modem", peer.url, kept)
        for _ in range(4):
            await station.contact()
        assert (peer.accepted, peer.refused, kept.reused) == (1, 0, 3)
        peer.close_all()
        await asyncio.sleep(0.2)
        for _ in range(2):
            await station.contact()
        assert (peer.accepted, peer.refused) == (2, 0)
        assert not station.twice()
        assert station.readings() == await reference(tmp_path, logger.url, _final(station))
        kept.close()
        await asyncio.sleep(0.1)
        assert not peer.links
        await peer.stop()

    asyncio.run(main())


def test_a_kept_connection_that_spoke_out_of_turn_is_not_reused(
    logger: Served, tmp_path: Path
) -> None:
    async def main() -> None:
        peer = await Peer(logger.port).start()
        kept = KeptConnections()
        station = Station(tmp_path, "chatty", peer.url, kept)
        await station.contact()
        (link,) = peer.links
        link.down[1].write(b"RING\r\n")  # bytes nobody asked for
        await asyncio.sleep(0.2)
        assert not peer.links  # closed at once: nothing held
        await station.contact()
        assert (peer.accepted, kept.reused) == (2, 0)
        kept.close()
        await peer.stop()

    asyncio.run(main())


def test_the_limit_bounds_the_connections_held(logger: Served, tmp_path: Path) -> None:
    async def main() -> None:
        kept = KeptConnections(limit=1)
        one = Station(tmp_path, "one", logger.url, kept)
        two = Station(tmp_path, "two", logger.url, kept)
        for _ in range(2):
            await one.contact()
            await two.contact()
        assert len(kept) == 1 and "one" in kept and (kept.opened, kept.reused) == (3, 1)
        kept.close()

    asyncio.run(main())


def test_reload_removing_a_source_closes_its_connection(logger: Served, tmp_path: Path) -> None:
    async def main() -> None:
        peers = [await Peer(logger.port).start() for _ in range(2)]
        sources = tuple(
            SourceConfig(name, p.url, interval=0.2, keep_open=True)
            for name, p in zip(("a", "b"), peers, strict=True)
        )
        config = CollectorConfig(
            tmp_path / "c.toml",
            tmp_path / "store.sqlite",
            True,
            tmp_path / "buffer.sqlite",
            sources,
            {},
        )
        collector = Collector(config)
        stop = asyncio.Event()
        run = asyncio.create_task(collector.run(stop))
        await _until(lambda: collector.kept.reused >= 4)
        assert [len(p.links) for p in peers] == [1, 1]
        await collector.reload(dataclasses.replace(config, sources=sources[:1]))
        await _until(lambda: not peers[1].links)
        assert "b" not in collector.kept
        contacts = collector.contacts
        await _until(lambda: collector.contacts >= contacts + 3)
        assert len(peers[0].links) == 1 and peers[0].accepted == 1 and peers[1].accepted == 1
        assert [s.config.name for s in collector.sources] == ["a"]
        added = SourceConfig("c", peers[1].url, interval=0.2, keep_open=True)
        await collector.reload(dataclasses.replace(config, sources=(sources[0], added)))
        await _until(lambda: "c" in collector.kept)  # a new source starts, and keeps its own
        assert peers[1].accepted == 2 and peers[0].accepted == 1
        stop.set()
        await run
        await _until(lambda: not peers[0].links and not peers[1].links)  # closed at the stop
        assert len(collector.kept) == 0
        for peer in peers:
            await peer.stop()

    asyncio.run(main())


async def _until(condition: Any, within: float = 10.0) -> None:
    deadline = time.monotonic() + within
    while not condition():
        assert time.monotonic() < deadline, "not within the time"
        await asyncio.sleep(0.02)


STEP = st.tuples(
    st.integers(0, 1),
    st.sampled_from(["contact", "close", "reset", "stall", "wait"]),
    st.integers(0, 3000),
)


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(steps=st.lists(STEP, min_size=1, max_size=14))
def test_interleaved_faults_lose_nothing_and_every_source_goes_on(
    logger: Served, tmp_path_factory: pytest.TempPathFactory, steps: list[tuple[int, str, int]]
) -> None:
    """Liveness under random closes, resets and stalls of the kept connections, in any order
    with the two sources' contacts: every contact succeeds (a fault costs one fresh
    connection), no reading is delivered twice, and what each stored is the logger's record
    up to its newest row."""
    tmp = tmp_path_factory.mktemp("steps")

    async def main() -> None:
        peers = [await Peer(logger.port).start() for _ in range(2)]
        kept = KeptConnections()
        stations = [Station(tmp, f"s{i}", p.url, kept, timeout=0.3) for i, p in enumerate(peers)]
        faults = [0, 0]
        for which, action, at in [*steps, (0, "contact", 0), (1, "contact", 0)]:
            if action == "contact":
                assert (await stations[which].contact()).startswith("logger ")
            elif action == "wait":
                await asyncio.sleep(at / 20000)
            else:
                faults[which] += peers[which].arm(action, at)
        for station in stations:
            assert not station.twice()
            assert station.readings() == await reference(tmp, logger.url, _final(station))
        assert kept.opened <= 2 + sum(faults)
        kept.close()
        for peer in peers:
            await peer.stop()

    asyncio.run(main())


def test_keep_open_is_checked_in_the_file(tmp_path: Path) -> None:
    from sondalog.collect.config import load_config
    from sondalog.config import ConfigError

    def load(source: str) -> CollectorConfig:
        path = tmp_path / "c.toml"
        path.write_text(source)
        return load_config(path)

    ok = load('[[source]]\nurl = "tcp://127.0.0.1:1"\nkeep_open = true\n')
    assert ok.sources[0].keep_open
    assert not load('[[source]]\nurl = "tcp://127.0.0.1:1"\n').sources[0].keep_open
    every = load(
        '[collect]\nkeep_open = true\n[[source]]\nurl = "tcp://127.0.0.1:1"\n'
        '[[source]]\nurl = "tcp://127.0.0.1:2"\nkeep_open = false\n'
        '[[source]]\nkind = "bus"\nurl = "tcp://127.0.0.1:3"\n'
        '[[source]]\nurl = "serial:///dev/ttyS0"\n'
    )
    assert [s.keep_open for s in every.sources] == [True, False, False, False]
    with pytest.raises(ConfigError, match=r":2: collect.keep_open: must be true or false"):
        load('[collect]\nkeep_open = "yes"\n[[source]]\nurl = "tcp://127.0.0.1:1"\n')
    with pytest.raises(ConfigError, match=r"collect.keep_opn"):
        load('[collect]\nkeep_opn = true\n[[source]]\nurl = "tcp://127.0.0.1:1"\n')
    for text, message in [
        ('url = "tcp://127.0.0.1:1"\nkeep_open = 1', ":3: source[0].keep_open: must be true"),
        ('url = "serial:///dev/ttyS0"\nkeep_open = true', "only a tcp:// connection"),
        (
            'kind = "bus"\nurl = "tcp://127.0.0.1:1"\nkeep_open = true',
            "only a logger source keeps",
        ),
    ]:
        with pytest.raises(ConfigError) as info:
            load(f"[[source]]\n{text}\n")
        assert message in str(info.value), str(info.value)

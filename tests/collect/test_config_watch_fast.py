"""The configuration watch at every contact, made cheap (issue 24): a check whose answers
equal the last recorded ones writes nothing and leaves the store's write-behind alone; a
change is still found and recorded with its diff; another logger (of the other protocol
version) answering at the source's URL is read with its own lines; the drift from an
``expect`` file is said at every check as before. Real served loggers over TCP."""

from __future__ import annotations

import asyncio
import sqlite3
from pathlib import Path

from served_logger import serving

from sondalog.client.ala1 import Ala1Client
from sondalog.client.station_file import read_station
from sondalog.client.station_logger import Session, identify, read_values
from sondalog.collect.config import SourceConfig
from sondalog.collect.config_watch import ConfigWatch, config_hash
from sondalog.collect.store_sqlite import SqliteStore
from sondalog.config import loads


async def _check(watch: ConfigWatch, url: str) -> str | None:
    async with await Ala1Client.connect(url, timeout=10) as client:
        return await watch.check(client)


async def _ask(url: str, *commands: str) -> None:
    """A technician's writes over the logger's line."""
    async with await Ala1Client.connect(url, timeout=10) as client:
        for answer in await client.pipeline(commands):
            assert answer.ok, answer


async def _pulled(url: str) -> tuple[str, dict[str, str]]:
    """What ``logger config pull`` reads: the version and every setting."""
    async with await Ala1Client.connect(url, timeout=10) as client:
        session = Session(client)
        ident = await identify(session)
        return ident.version, await read_values(session, ident.version)


def _history(path: Path) -> list[tuple[str, str | None, str, str]]:
    with sqlite3.connect(path) as db:
        return db.execute(
            "SELECT logger, old_hash, new_hash, diff FROM config_history ORDER BY id"
        ).fetchall()


def test_an_unchanged_configuration_touches_nothing_and_a_change_is_recorded(
    tmp_path: Path,
) -> None:
    path = tmp_path / "store.sqlite"

    async def run(logger_url: str) -> list[str | None]:
        store = SqliteStore(path).open_sync()
        store.write_behind = 30.0  # the collector's: contacts' writes wait in memory
        watch = ConfigWatch(SourceConfig(name="s", url=logger_url), store)
        said = [await _check(watch, logger_url)]  # the first: read, compared, stored
        store.set_state("s", last_contact="now")  # another contact's write, pending
        said += [await _check(watch, logger_url) for _ in range(3)]
        assert store.pending  # no check flushed it: they wrote nothing
        await _ask(logger_url, "write channel 2 sampling period 000030", "write command 3 value/x/")
        said.append(await _check(watch, logger_url))
        said.append(await _check(watch, logger_url))
        version, values = await _pulled(logger_url)
        store.close_sync()
        (*_, new_hash, _), *_ = _history(path)[-1:]
        assert new_hash == config_hash(values, version)  # exactly what pull reads
        return said

    with serving(tmp_path) as logger:
        said = asyncio.run(run(logger.url))
    assert said[0] is not None and said[0].startswith("configuration read: ")
    assert said[1:4] == ["configuration unchanged"] * 3
    assert said[4:] == ["configuration changed", "configuration unchanged"]
    first, change = _history(path)
    assert change[1] == first[2] and change[3].splitlines() == [
        "channel 2 sampling period: 000000 -> 000030",
        "command 3 value: (empty) -> x",
    ]


def test_another_logger_of_the_other_version_at_the_url(tmp_path: Path) -> None:
    """The watch reads the identity with its first lines, assuming the last version; a 1.16
    logger where a 2.10 one was (and back) is read whole with its own lines."""
    path = tmp_path / "store.sqlite"

    async def run(old: str, new: str) -> list[str | None]:
        store = SqliteStore(path).open_sync()
        watch = ConfigWatch(SourceConfig(name="s", url=old), store)
        said = [await _check(watch, url) for url in (old, old, new, new, old)]
        for url in (old, new):
            version, values = await _pulled(url)
            assert config_hash(values, version) in [row[2] for row in _history(path)]
        store.close_sync()
        return said

    with (
        serving(tmp_path, "--protocol", "2.10", "--serial-number", "000210", name="a") as a,
        serving(tmp_path, "--protocol", "1.16", "--serial-number", "000116", name="b") as b,
    ):
        a.ask("write channel 1 name/a,b/")
        b.ask("write channel 8 name/OK/")
        said = asyncio.run(run(a.url, b.url))
    assert said[1] == said[3] == said[4] == "configuration unchanged"
    assert said[2] is not None and said[2].startswith("configuration read: ")
    assert [row[0] for row in _history(path)] == ["000210", "000116"]


def test_the_drift_is_said_at_every_check(tmp_path: Path) -> None:
    station = read_station(loads('protocol = "2.10"\n[identity]\nname = "weir"\n'))

    async def run(url: str) -> list[str | None]:
        store = SqliteStore(tmp_path / "store.sqlite").open_sync()
        config = SourceConfig(name="s", url=url, expect=station, expect_path="st.toml")
        watch = ConfigWatch(config, store)
        said = [await _check(watch, url) for _ in range(3)]
        store.close_sync()
        return said

    with serving(tmp_path) as logger:
        said = asyncio.run(run(logger.url))
    assert said[0] is not None and said[0].endswith(", drifts from st.toml (1 setting)")
    assert said[1:] == ["configuration unchanged, drifts from st.toml (1 setting)"] * 2


def test_a_failed_read_makes_the_next_check_identify_the_logger_first(tmp_path: Path) -> None:
    """A read that fails (here the line closes in the middle) leaves an event, and the next
    check does not assume the version it had: it reads the identity first, so whatever
    answers at the URL next is read with its own lines."""

    async def run(url: str) -> list[str | None]:
        async def hang_up(_: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            writer.write(b"2.10\r\n")
            await writer.drain()
            writer.close()

        server = await asyncio.start_server(hang_up, "127.0.0.1", 0)
        broken = f"tcp://127.0.0.1:{server.sockets[0].getsockname()[1]}"
        store = SqliteStore(tmp_path / "store.sqlite").open_sync()
        watch = ConfigWatch(SourceConfig(name="s", url=url), store)
        said = [await _check(watch, url)]
        assert watch._version == "2.10"
        async with server:
            said.append(await _check(watch, broken))
        assert watch._version is None
        said.append(await _check(watch, url))
        assert watch._version == "2.10"
        store.close_sync()
        return said

    with serving(tmp_path) as logger:
        said = asyncio.run(run(logger.url))
    assert said[1] is not None and said[1].startswith("configuration not read: ")
    assert said[2] == "configuration unchanged"

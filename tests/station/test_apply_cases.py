"""Plan and apply on served virtual loggers: a refusal in the middle, the other protocol
version, an i address, conversion tables, bad files (issue 22)."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from station_helpers import ask, every_read, explain_text, served

from sondalog.client import Ala1Client
from sondalog.client.ala1_codec import ClientError
from sondalog.client.station_apply import Refused, apply, make_plan, pull
from sondalog.client.station_file import read_station
from sondalog.client.station_fleet import read_file
from sondalog.config import ConfigError, load, loads

TABLE = b"0 0\n10 100\n"


def _station(tmp: Path, text: str):  # type: ignore[no-untyped-def]
    path = tmp / "station.toml"
    path.write_text(text)
    return read_station(load(path))


def test_a_refused_write_stops_and_says_what_was_and_was_not_applied(tmp_path: Path) -> None:
    station = _station(
        tmp_path,
        '[device.2]\ntype = "DS18B20"\n[record]\ntype = "LINEAR"\n[channel.2]\nname = "Hladina"\n',
    )

    async def run() -> None:
        async with served(tmp_path / "a") as a:
            assert await ask(a.url, ["write channel value"]) == ["OK"]  # a row: not empty
            outcome = await apply(a.url, station, explain_text)
            assert outcome.applied == [
                "device 2 type: MSP430ADC -> DS18B20  (restores its factory calibration, §6.4.4.3)"
            ]
            assert outcome.error is not None
            assert outcome.error.startswith("record type: the logger refused")
            assert "record type only while the record is empty" in outcome.error  # :explain
            assert outcome.not_applied == [
                "record type: CYCLIC -> LINEAR  (only while the record is empty)",
                "channel 2 name: Supply[V] -> Hladina",
            ]
            plan = await make_plan(a.url, station)  # nothing after the refusal was written
            assert [c.name for c in plan.changes] == ["record type", "channel 2 name"]

    asyncio.run(run())


def test_a_file_of_the_other_version_is_translated_or_refused_before_any_write(
    tmp_path: Path,
) -> None:
    refused = _station(
        tmp_path,
        'protocol = "2.10"\n[channel.3]\nname = "Voda"\n[channel.10]\nname = "Vitr"\n'
        '[message.1]\naddress = "1,2"\n',
    )
    fits = _station(
        tmp_path, 'protocol = "2.10"\n[channel.3]\nname = "Voda"\n[channel.10]\nformat = "0.1"\n'
    )

    async def run() -> None:
        async with served(tmp_path / "old", "1.16") as old:
            with pytest.raises(Refused) as caught:
                await apply(old.url, refused, explain_text)
            path = tmp_path / "station.toml"
            assert caught.value.problems == [
                f"{path}:5: channel.10.name: a 1.16 logger has no channel 10 name",
                f"{path}:7: message.1.address: a 1.16 logger refuses it: at most 1 address numbers",
            ]
            assert await ask(old.url, ["read channel 3 name"]) == ["OK"]
            plan = await make_plan(old.url, fits)
            assert plan.notes == [
                "the file is for protocol 2.10, the logger speaks 1.16: 1 settings carry over"
                " unchanged",
                "left out (factory values, not in 1.16): channel 10 format",
            ]
            assert [c.describe() for c in plan.changes] == ["channel 3 name: Supply[V] -> Voda"]
            outcome = await apply(old.url, fits, explain_text)
            assert outcome.error is None and len(outcome.applied) == 1

    asyncio.run(run())


def test_an_i_address_is_written_last_and_then_carried_by_every_line(tmp_path: Path) -> None:
    station = _station(tmp_path, '[identity]\naddress = "A1"\nname = "Brod"\n')

    async def run() -> None:
        async with served(tmp_path / "a") as a:
            outcome = await apply(a.url, station, explain_text)
            assert outcome.error is None
            assert outcome.applied[-1].startswith("i address: (empty) -> A1")
            assert await ask(a.url, ["read i name"], iaddress="A1") == ["OK"]
            assert (await make_plan(a.url, station)).empty  # the file's address is used
            with pytest.raises(ClientError, match="no ALA1 answer"):
                await pull(a.url)  # a guarded logger does not answer without it
            text, _ = await pull(a.url, iaddress="A1")
            assert 'address = "A1"' in text and 'name = "Brod"' in text

    asyncio.run(run())


def test_tables_are_sent_after_the_partition_and_pulled_beside_the_file(tmp_path: Path) -> None:
    (tmp_path / "t").mkdir()
    (tmp_path / "t" / "Tlevel.txt").write_bytes(TABLE)
    station = _station(
        tmp_path,
        '[channel.1]\ntable1 = "Tlevel"\n[file]\nrecord_size = 1047552\nlist_size = 512\n'
        'data_size = 512\n[tables]\nTlevel = "t/Tlevel.txt"\n',
    )

    async def run() -> None:
        async with served(tmp_path / "a") as a:
            outcome = await apply(a.url, station, explain_text)
            assert outcome.error is None, outcome.error
            assert outcome.applied[3] == "conversion tables"
            assert "channel 1 convert 1 file name: (empty) -> Tlevel" in outcome.applied[4]
            assert (await make_plan(a.url, station)).empty
            text, tables = await pull(a.url, tables_dir="station.tables/")
            assert tables == {"Tlevel": TABLE}
            assert '[tables]\nTlevel = "station.tables/Tlevel.txt"' in text
            (tmp_path / "station.tables").mkdir()
            (tmp_path / "station.tables" / "Tlevel.txt").write_bytes(tables["Tlevel"])
            (tmp_path / "pulled.toml").write_text(text)
            assert (await make_plan(a.url, read_station(load(tmp_path / "pulled.toml")))).empty

    asyncio.run(run())


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("[channel.3]\nsampling_perod = 1\n", "<config>:2: channel.3.sampling_perod: unknown"),
        ("[channel.3]\nsampling_period = \"970000\"\n",
         "<config>:2: channel.3.sampling_period: 970000: at most 96 hours"),
        ("[channel.13]\nname = \"x\"\n", "<config>:1: channel.13: unknown"),
        ('protocol = "1.16"\n[channel.9]\nname = "x"\n', "<config>:2: channel.9: unknown"),
        ("[channel.1]\nname = \"Hladina vody u mostu!\"\n",
         "<config>:2: channel.1.name: at most 20 characters"),
        ("[channel.1]\naddress = -1\n", "<config>:2: channel.1.address: an integer 0.."),
        ("[channel.1]\ndevice = \"1\"\n", "<config>:2: channel.1.device: must be an integer"),
        ("[identity]\nname = \"Brod\u00e9\"\n", "printable ASCII"),
        ("[comand.1]\nname = \"x\"\n", "<config>: comand: unknown"),
    ],
)  # fmt: skip
def test_values_the_grammar_refuses_are_refused_with_line_and_field(text: str, error: str) -> None:
    with pytest.raises(ConfigError) as caught:
        read_station(loads(text))
    assert error in str(caught.value)


def test_did_you_mean(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"did you mean sampling_period\?"):
        read_station(loads("[channel.3]\nsampling_perod = 1\n"))
    with pytest.raises(ConfigError, match=r"did you mean command\?"):
        read_station(loads("[comand.1]\nname = 'x'\n"))


def test_a_fleet_file_is_a_template_with_per_logger_overrides(tmp_path: Path) -> None:
    path = tmp_path / "fleet.toml"
    path.write_text(
        '[channel.1]\nsampling_period = "001000"\nname = "Teplota"\n'
        '[[logger]]\nurl = "tcp://127.0.0.1:1"\nserial_number = "A7"\n'
        '[logger.identity]\nname = "Brod"\n[logger.channel.1]\nname = "Hladina"\n'
        '[[logger]]\nurl = "tcp://127.0.0.1:2"\n'
    )
    first, second = read_file(path)
    assert first.url == "tcp://127.0.0.1:1" and first.station.serial_number == "A7"
    assert first.station.values == {
        "channel 1 sampling period": "001000",
        "channel 1 name": "Hladina",
        "i name": "Brod",
    }
    assert second.station.values == {
        "channel 1 sampling period": "001000",
        "channel 1 name": "Teplota",
    }
    path.write_text(
        '[[logger]]\nurl = "tcp://127.0.0.1:1"\n[[logger]]\nurl = "tcp://127.0.0.1:1"\n'
    )
    with pytest.raises(ConfigError, match=r"fleet.toml:4: logger\[1\].url: .* is also logger\[0\]"):
        read_file(path)
    path.write_text('[[logger]]\nurl = "http://x"\n')
    with pytest.raises(ConfigError, match=r"logger\[0\].url: unsupported URL"):
        read_file(path)


def test_another_serial_number_is_refused(tmp_path: Path) -> None:
    station = _station(tmp_path, 'serial_number = "A7"\n[identity]\nname = "Brod"\n')

    async def run() -> None:
        async with served(tmp_path / "a") as a:
            with pytest.raises(Refused, match="the file is for logger A7; this is logger 000001"):
                await apply(a.url, station, explain_text)

    asyncio.run(run())


def test_the_memory_partition_and_the_tables_are_checked_before_any_write(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"<config>:3: file.list_size: the areas take 1048832"):
        read_station(loads("[file]\n\nlist_size = 256\n"))
    (tmp_path / "T.txt").write_bytes(TABLE)
    with pytest.raises(
        ConfigError,
        match=r"station.toml:1: tables: the tables need 5 bytes of file list size, which is 0",
    ):
        _station(tmp_path, '[tables]\nT = "T.txt"\n')
    fleet = tmp_path / "fleet.toml"  # the template's partition, an entry's tables: fine
    fleet.write_text(
        "[file]\nrecord_size = 1047552\nlist_size = 512\ndata_size = 512\n"
        '[[logger]]\nurl = "tcp://127.0.0.1:1"\n[logger.tables]\nT = "T.txt"\n'
    )
    (target,) = read_file(fleet)
    assert target.station.tables == {"T": tmp_path / "T.txt"}


def test_plan_touches_nothing(tmp_path: Path) -> None:
    station = _station(tmp_path, '[file]\nrecord_size = 524288\n[channel.2]\nname = "Voda"\n')

    async def run() -> None:
        async with served(tmp_path / "a") as a:
            assert await ask(a.url, ["write channel value", "write channel 1 name/Supply/"]) == [
                "OK",
                "OK",
            ]
            before = await every_read(a.url, "2.10")
            rows = await _rows(a.url)
            assert len(rows) == 1
            plan = await make_plan(a.url, station)
            assert [c.name for c in plan.changes] == [
                "file record size",
                "channel 1 name",
                "channel 2 name",
            ]
            assert await every_read(a.url, "2.10") == before
            assert await _rows(a.url) == rows  # planning a record size erases nothing

    asyncio.run(run())


async def _rows(url: str) -> tuple[str, ...]:
    async with await Ala1Client.connect(url) as client:
        return (await client.command("read record 10 from start")).raise_for_error().lines

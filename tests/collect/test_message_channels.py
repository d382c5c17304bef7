"""A logger known only from its messages: names and units from the message source's
``channels`` (issue 26), unless a download asked the logger for them."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

from sondalog.collect.config import load_config
from sondalog.collect.message_sources import MessageIntake
from sondalog.collect.model import Reading
from sondalog.collect.store_sqlite import SqliteStore
from sondalog.config import ConfigError

CONFIG = """[sqlite]
path = "s.sqlite"

[[source]]
name = "mail"
kind = "mailbox"
url = "pop3://user@example.net:secret@127.0.0.1:1110"
logger = "GSM-03"
credit = 4
channels = { 1 = "Supply [V]", 2 = "Soil [C]", 3 = "Signal", 4 = "Credit [CZK]" }
"""
BODY = "20260301120000.0,1,12.1,8.5,18,250.0\r\n20260301121500.0,1,12.2,8.4,19,250.0\r\nOK\r\n"


def _intake(tmp_path: Path, text: str) -> tuple[MessageIntake, SqliteStore]:
    path = tmp_path / "c.toml"
    path.write_text(text, encoding="utf-8")
    config = load_config(path)
    store = SqliteStore(config.store).open_sync()
    return MessageIntake(config.sources[0], store), store


def _take(intake: MessageIntake, store: SqliteStore) -> None:
    async def deliver(source: str, batch: list[Reading], cursor: str | None, **state: Any) -> None:
        store.commit_chunk(source, batch, cursor, **state)

    assert asyncio.run(intake.take(deliver, "logger@example.net", BODY, None))


def test_names_and_units_from_the_source_reach_the_store(tmp_path: Path) -> None:
    intake, store = _intake(tmp_path, CONFIG)
    assert intake.config.channels == {
        1: "Supply [V]",
        2: "Soil [C]",
        3: "Signal",
        4: "Credit [CZK]",
    }
    _take(intake, store)
    channels = store.db.execute(
        "SELECT channel, name, unit, type FROM channels WHERE logger = 'GSM-03' ORDER BY channel"
    ).fetchall()
    assert channels == [
        (1, "Supply", "V", None),
        (2, "Soil", "C", None),
        (3, "Signal", None, None),
        (4, "Credit", "CZK", 11),
    ]
    readings = store.db.execute(
        "SELECT DISTINCT channel, name, unit FROM readings ORDER BY channel"
    ).fetchall()
    assert readings == [
        (1, "Supply", "V"),
        (2, "Soil", "C"),
        (3, "Signal", None),
        (4, "Credit", "CZK"),
    ]
    store.close_sync()


def test_a_download_s_names_win(tmp_path: Path) -> None:
    intake, store = _intake(tmp_path, CONFIG)
    store.set_channels("GSM-03", [(1, "Battery", "V", 1)])
    _take(intake, store)
    rows = store.db.execute("SELECT channel, name FROM channels WHERE logger = 'GSM-03'").fetchall()
    assert rows == [(1, "Battery")]
    store.close_sync()


@pytest.mark.parametrize(
    ("value", "needle"),
    [
        ('"Air [C]"', "must be a table of channel number"),
        ('{ x = "Air [C]" }', "channels.x: not a channel number"),
        ("{ 1 = 5 }", "channels.1: must be a name"),
    ],
)
def test_bad_channels_are_a_config_error(tmp_path: Path, value: str, needle: str) -> None:
    text = CONFIG.replace(CONFIG.splitlines()[-1], f"channels = {value}")
    with pytest.raises(ConfigError, match=needle) as err:
        _intake(tmp_path, text)
    assert "c.toml:10:" in str(err.value)  # the line of channels


def test_only_a_message_source_has_channels(tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    path.write_text('[[source]]\nurl = "tcp://127.0.0.1:1"\nchannels = { 1 = "A" }\n')
    with pytest.raises(ConfigError, match="only a mailbox or network source has it"):
        load_config(path)

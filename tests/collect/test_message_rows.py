"""A logger's data message -> rows (§6.14, §6.8.4.1): decorations, crcsum, identification;
the message sources' configuration."""

from __future__ import annotations

from pathlib import Path

import pytest

from sondalog.collect.config import CollectorConfig, load_config
from sondalog.collect.message_rows import MessageError, MessageRows, identify, parse_message
from sondalog.collect.message_url import Pop3Url, parse_pop3_url
from sondalog.config import ConfigError
from sondalog.protocol.cksum import cksum

ROWS = ["20261130010000.0,1,12.6,0.250", "20261130010000.1,1,12.6,", "20261130020000.0,3,door open"]


def _crc(lines: list[str]) -> str:
    blob = "".join(line + "\r\n" for line in lines).encode()
    return f"{cksum(blob)},{len(blob)}"


def test_plain_rows_and_ok() -> None:
    got = parse_message("\r\n".join([*ROWS, "OK"]) + "\r\n")
    assert [r.key for r in got.rows] == [r.split(",")[0] for r in ROWS]
    assert got.rows[0].values == (12.6, 0.25) and got.rows[1].values == (12.6, None)
    assert got.rows[2].text == "door open" and got.name is None


def test_decorated_lines_give_the_rows_and_the_i_name() -> None:
    # sum, iname, date and counter decorations (spec notes §3 order) before each line
    lines = [f"00713,station-7,20261130030000,{n},{row}" for n, row in enumerate(ROWS)]
    got = parse_message("\r\n".join([*lines, "00154,station-7,20261130030000,3,OK"]))
    assert got.name == "station-7" and len(got.rows) == 3
    assert got.rows[0].values == (12.6, 0.25)


def test_crcsum_is_checked() -> None:
    lines = [f"{n},{row}" for n, row in enumerate(ROWS)]
    good = [*lines, f"3,{_crc(lines)}", "4,OK"]
    assert len(parse_message("\r\n".join(good)).rows) == 3
    bad = [lines[0], lines[1].replace("12.6", "13.6"), lines[2], f"3,{_crc(lines)}", "4,OK"]
    with pytest.raises(MessageError, match="crcsum"):
        parse_message("\r\n".join(bad))


@pytest.mark.parametrize(
    ("body", "why"),
    [
        ("000001\r\nOK\r\n", "not a record row"),
        ("OK\r\n", "no record rows"),
        ("", "no record rows"),
        ("20261130010000.0,1,12.6\r\nhello there\r\nOK", "not a record row"),
        ("20261399010000.0,1,12.6\r\nOK", "impossible date"),
        ("a,20261130010000.0,1,1\r\nb,20261130010000.1,1,2\r\nOK", "several loggers"),
    ],
)
def test_malformed_bodies_are_refused_whole(body: str, why: str) -> None:
    with pytest.raises(MessageError, match=why):
        parse_message(body)


def test_identification_order() -> None:
    rows = parse_message(ROWS[0]).rows
    named = MessageRows(rows, "station-7")
    plain = MessageRows(rows)
    loggers = {"station-7": "000007", "+420600000001": "000001"}
    assert identify(named, "+420600000001", loggers, "000009") == "000007"
    assert identify(MessageRows(rows, "other"), "+420600000001", loggers, None) == "other"
    assert identify(plain, "+420600000001", loggers, "000009") == "000001"
    assert identify(plain, "+420699999999", loggers, "000009") == "000009"
    assert identify(plain, "+420699999999", loggers, None) is None


MAILBOX = """[[source]]
kind = "mailbox"
url = "pop3://user@example.net:secret@127.0.0.1:1110"
logger = "000001"
keep = true

[[source]]
kind = "network"
url = "http://127.0.0.1:8025"
number = "+420700000001"
loggers = { "+420600000001" = "000001" }
"""


def _config(tmp_path: Path, text: str) -> CollectorConfig:
    path = tmp_path / "collector.toml"
    path.write_text(text)
    return load_config(path)


def test_message_source_config(tmp_path: Path) -> None:
    mailbox, network = _config(tmp_path, MAILBOX).sources
    assert (mailbox.kind, mailbox.logger, mailbox.keep) == ("mailbox", "000001", True)
    assert parse_pop3_url(mailbox.url) == Pop3Url("127.0.0.1", 1110, "user@example.net", "secret")
    assert (network.number, network.loggers) == ("+420700000001", {"+420600000001": "000001"})


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("pop3://user@example.net:secret@", "pop3://user@", r"source\[0\].url: .*USER:PASSWORD"),
        ("pop3://", "imap://", r":3: source\[0\].url: a mailbox URL is pop3://"),
        ('number = "+420700000001"\n', "", r"source\[1\].number: required"),
        ("keep = true", 'number = "1"', r"source\[0\].number: only a network source"),
        ('"000001" }', "1 }", r"source\[1\].loggers: must be a table"),
        ("http://127", "tcp://127", r"source\[1\].url: a network source's URL"),
    ],
)
def test_bad_message_source_config(tmp_path: Path, old: str, new: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        _config(tmp_path, MAILBOX.replace(old, new, 1))


def test_logger_sources_refuse_message_keys(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"source\[0\].keep: only a mailbox or network"):
        _config(tmp_path, '[[source]]\nurl = "tcp://127.0.0.1:1"\nkeep = true\n')

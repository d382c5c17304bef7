"""The mailbox source against the real mail hub (SMTP in, POP3 out) and a real served logger:
rows a logger sent by e-mail arrive in the store once, also when downloaded too; a malformed
mail is skipped with an event and never stored."""

from __future__ import annotations

import asyncio
import contextlib
import smtplib
import socket
import sqlite3
import threading
import time
from collections.abc import Iterator
from email.message import EmailMessage
from pathlib import Path

from served_logger import Served, configure, sampling_logger

from sondalog.app.mailhub import MailHub, MailHubConfig
from sondalog.client.records import parse_row
from sondalog.collect.config import load_config
from sondalog.collect.runner import Collector

ACCOUNTS = {"logger@example.net": "secret", "user@example.net": "secret"}


def _mail(port: int, sender: str, body: str) -> None:
    message = EmailMessage()
    message["From"], message["To"], message["Subject"] = sender, "user@example.net", "ALA1"
    message.set_content(body)
    with smtplib.SMTP("127.0.0.1", port, timeout=10) as smtp:
        smtp.send_message(message)


def _rows(served: Served, count: int) -> list[str]:
    deadline = time.monotonic() + 20
    while len(rows := served.record()) < count and time.monotonic() < deadline:
        time.sleep(0.2)
    assert len(rows) >= count
    return rows


def _raw(served: Served, command: str) -> str:
    """The answer to ``command`` exactly as the logger sends it."""
    with socket.create_connection(("127.0.0.1", served.port), timeout=10) as sock:
        sock.sendall(command.encode() + b"\r")
        data = b""
        while not data.endswith(b"OK\r\n"):
            data += sock.recv(4096)
    return data.decode("latin-1")


def _query(store: Path, sql: str) -> list[tuple[object, ...]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        return db.execute(sql).fetchall()


def _collect(path: Path) -> None:
    asyncio.run(Collector(load_config(path)).run(asyncio.Event(), once=True))


@contextlib.contextmanager
def _hub(root: Path) -> Iterator[MailHub]:
    """The real mail hub, served by an event loop in a thread while the test runs."""
    loop = asyncio.new_event_loop()
    hub = MailHub(MailHubConfig(root, ACCOUNTS, smtp_port=0, pop3_port=0))
    loop.run_until_complete(hub.start())
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield hub
    finally:
        asyncio.run_coroutine_threadsafe(hub.stop(), loop).result(10)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(10)
        loop.close()


def test_mailbox_rows_arrive_once_and_bad_mail_is_skipped(tmp_path: Path) -> None:
    with _hub(tmp_path / "mail") as hub:
        with sampling_logger(tmp_path) as served:
            configure(served)
            _rows(served, 6)
            # the answer of the message's command as the logger sends it: counter-numbered
            # lines with a crcsum (§8.5.7, §8.4.1)
            body = _raw(served, "counter 1 crcsum read record 4 from start")
            assert body.count("\r\n") == 6  # four rows, the crcsum line, OK
            _mail(hub.smtp_port, "logger@example.net", body)
            _mail(hub.smtp_port, "logger@example.net", "20261301000000.0,1,1\r\nOK\r\n")
            _mail(hub.smtp_port, "stranger@example.org", "20261130000000.0,1,1\r\nOK\r\n")
            config = tmp_path / "collect.toml"
            config.write_text(
                f"""[web]\nenabled = false\n
[[source]]
name = "mail"
kind = "mailbox"
url = "pop3://user@example.net:secret@127.0.0.1:{hub.pop3_port}"
loggers = {{ "logger@example.net" = "000001" }}
signal = 2
"""
            )
            _collect(config)
            store = tmp_path / "collector.sqlite"
            mailed = [parse_row(line.split(",", 1)[1]) for line in body.split("\r\n")[:4]]
            expected = {
                (r.time.isoformat(), r.counter, ch)
                for r in mailed
                for ch, v in enumerate(r.values, start=1)
                if v is not None
            }
            got = _query(store, "SELECT time, counter, channel FROM readings")
            assert set(got) == expected and len(got) == len(expected)
            events = [e[0] for e in _query(store, "SELECT text FROM events WHERE kind='message'")]
            assert any("logger 000001, 4 rows" in e for e in events), events
            assert any("impossible date" in e for e in events), events
            assert any("stranger@example.org skipped: unknown logger" in e for e in events)
            box = hub.maildir("user@example.net")
            assert not [*(box / "new").iterdir(), *(box / "cur").iterdir()]  # all read, deleted
            # the newest value of the channel named the GSM signal is the source's signal
            state = _query(store, "SELECT logger, signal FROM sources WHERE name = 'mail'")
            assert state == [("000001", mailed[-1].values[1])]
            # the same rows downloaded too: stored once, the download adds only the newer rows
            config.write_text(
                config.read_text() + f'\n[[source]]\nname = "cable"\nurl = "{served.url}"\n'
            )
            _collect(config)
            record = served.record()
        rows = _query(
            store,
            "SELECT logger, time, counter, channel, COUNT(*) FROM readings "
            "GROUP BY logger, time, counter, channel",
        )
        assert all(r[0] == "000001" and r[4] == 1 for r in rows)
        downloaded = {(parse_row(x).time.isoformat(), parse_row(x).counter) for x in record}
        assert {(r[1], r[2]) for r in rows} <= downloaded
        assert len({(r[1], r[2]) for r in rows}) >= len(mailed)


def test_mailbox_keep_leaves_the_mail_and_reads_it_once(tmp_path: Path) -> None:
    with _hub(tmp_path / "mail") as hub:
        _mail(hub.smtp_port, "logger@example.net", "20261130010000.0,1,1.5\r\nOK\r\n")
        config = tmp_path / "collect.toml"
        config.write_text(
            f"""[web]\nenabled = false\n
[[source]]
name = "mail"
kind = "mailbox"
url = "pop3://user@example.net:secret@127.0.0.1:{hub.pop3_port}"
logger = "000009"
keep = true
"""
        )
        _collect(config)
        _mail(hub.smtp_port, "logger@example.net", "20261130020000.0,1,2.5\r\nOK\r\n")
        _collect(config)
        store = tmp_path / "collector.sqlite"
        assert _query(store, "SELECT logger, value FROM readings ORDER BY time") == [
            ("000009", 1.5),
            ("000009", 2.5),
        ]
        stored = _query(store, "SELECT text FROM events WHERE kind = 'message'")
        assert len(stored) == 2  # each mail read once, though both stay in the mailbox
        box = hub.maildir("user@example.net")
        assert len([*(box / "new").iterdir(), *(box / "cur").iterdir()]) == 2

"""The collector's network source against the served example world (docs/gsm.md): the logger
sends its new record rows by SMS (in two SMS: the rows do not fit in one) through its
modem and the network; the collector reads them from the network's API into the store, once,
also when the same rows are downloaded over the cable line; a stray SMS is skipped."""

from __future__ import annotations

import asyncio
import contextlib
import signal
import socket
import sqlite3
import time
from functools import partial
from pathlib import Path

from gsm_served import MODEM, PHONE, PHONE2
from test_example_world import _api, _ask, _port, _start, _wait_sms

from sondalog.client.records import parse_row
from sondalog.collect.config import load_config
from sondalog.collect.runner import Collector


def _query(store: Path, sql: str) -> list[tuple[object, ...]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        return db.execute(sql).fetchall()


def _collect(config: Path) -> None:
    asyncio.run(Collector(load_config(config)).run(asyncio.Event(), once=True))


def test_rows_sent_by_sms_arrive_in_the_store_once(tmp_path: Path) -> None:
    proc, lines = _start(tmp_path)
    try:
        cable_port = _port(lines, "logger ")
        with socket.create_connection(("127.0.0.1", cable_port)) as cable:
            cable.settimeout(10)
            for command in (
                "write channel max number 1 write channel 1 record change 0",
                "write channel sampling period 000001",
                "write command 1 value/read record 1000 from lastread shift/",
                f"write address 1 type sms write address 1 value {PHONE}",
                "write message 1 address 1 write message 1 command 1",
                "write com device wavecom41",
            ):
                assert _ask(cable, command) == b"OK\r\n", command
            time.sleep(9)  # rows of 24 characters: more than one SMS can carry
            assert _ask(cable, "write message 1 run 1") == b"OK\r\n"
            assert _ask(cable, "write com close") == b"OK\r\n"
        texts = _wait_sms(lines, PHONE, "OK\r\n")
        assert len(texts) == 2 and len(texts[0]) == 160, texts  # one answer in two SMS
        mailed = [parse_row(x) for x in "".join(texts).split("\r\n")[:-2]]
        _api(lines, "POST", "/sms", {"from": PHONE2, "to": PHONE, "text": "hello, logger"})
        api = f"http://127.0.0.1:{_port(lines, 'gsm API')}"
        config = tmp_path / "collect.toml"
        config.write_text(
            f"""[web]\nenabled = false\n
[[source]]
name = "sms"
kind = "network"
url = "{api}"
number = "{PHONE}"
loggers = {{ "{MODEM}" = "000001", "{PHONE2}" = "000002" }}
"""
        )
        collect = partial(_collect, config)
        collect()
        store = tmp_path / "collector.sqlite"
        got = _query(store, "SELECT logger, time, counter, channel FROM readings")
        assert sorted(got) == sorted(("000001", r.time.isoformat(), r.counter, 1) for r in mailed)
        events = [e[0] for e in _query(store, "SELECT text FROM events WHERE kind='message'")]
        assert any(f"logger 000001, {len(mailed)} rows" in e for e in events), events
        assert any(f"{PHONE2} skipped" in e for e in events), events
        # an answer split into plain SMS of 160 characters: the first part waits for the rest
        body = "".join(f"20261130{h:02d}0000.0,1,{h}.5\r\n" for h in range(7)) + "OK\r\n"
        _api(lines, "POST", "/sms", {"from": PHONE2, "to": PHONE, "text": body[:160]})
        collect()
        two = "SELECT value FROM readings WHERE logger = '000002' ORDER BY time"
        assert _query(store, two) == []
        _api(lines, "POST", "/sms", {"from": PHONE2, "to": PHONE, "text": body[160:]})
        collect()
        assert _query(store, two) == [(h + 0.5,) for h in range(7)]
        events = [e[0] for e in _query(store, "SELECT text FROM events WHERE kind='message'")]
        # again, with the cable line downloaded too: nothing twice, nothing read again
        config.write_text(
            config.read_text()
            + f'\n[[source]]\nname = "cable"\nurl = "tcp://127.0.0.1:{cable_port}"\n'
        )
        collect()
        counts = _query(
            store, "SELECT COUNT(*) FROM readings GROUP BY logger, time, counter, channel"
        )
        assert counts and all(c == (1,) for c in counts) and len(counts) >= len(mailed)
        assert len(_query(store, "SELECT 1 FROM events WHERE kind='message'")) == len(events)
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(15)

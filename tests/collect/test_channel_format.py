"""A channel's value format reaches the dashboard (issue 26): the collector reads it from
the logger with the channel types, in the same line, and the page writes each value with
the format's decimals (§4.3.5, §6.5.7), also a value whose decimals are all zeros."""

from __future__ import annotations

import sqlite3
import subprocess
import time
from pathlib import Path

from served_logger import CLI, configure, sampling_logger

from sondalog.collect.store_sqlite import SqliteStore
from sondalog.web import store as web_store
from sondalog.web.pages import _num


def test_the_logger_s_format_is_stored_and_shown(tmp_path: Path) -> None:
    store = tmp_path / "store.sqlite"
    config = tmp_path / "c.toml"
    with sampling_logger(tmp_path) as served:
        configure(served)  # channel 2: format 0.3
        served.ask("write channel 1 format 5.2")
        time.sleep(1.0)  # a few rows at --speed 50
        served.ask("write channel sampling period 000000 000000")
        config.write_text(f'[sqlite]\npath = "{store}"\n\n[[source]]\nurl = "{served.url}"\n')
        done = subprocess.run(
            [*CLI, "collect", "--once", str(config)], capture_output=True, timeout=60
        )
        assert done.returncode == 0, done.stderr
        snumber = served.ask("read i snumber")[0]
    conn = sqlite3.connect(store)
    formats = conn.execute(
        "SELECT channel, format FROM channels WHERE logger = ? ORDER BY channel", (snumber,)
    ).fetchall()
    assert formats == [(1, "5.2"), (2, "0.3")]
    # a stored value that happens to be whole still shows the format's decimals
    conn.execute("UPDATE readings SET value = 12.0 WHERE channel = 1")
    conn.commit()
    channels = {c.channel: c for c in web_store.channels(web_store.of_file(conn), snumber)}
    assert channels[1].decimals == 2 and channels[2].decimals == 3
    assert _num(12.0, 4, channels[1].decimals) == "12.00"


def test_a_store_from_before_gains_the_format_column(tmp_path: Path) -> None:
    path = tmp_path / "old.sqlite"
    store = SqliteStore(path).open_sync()
    store.close_sync()
    conn = sqlite3.connect(path)  # as an older sondalog left it: no format column
    conn.execute("DROP TABLE channels")
    conn.execute(
        "CREATE TABLE channels (logger TEXT NOT NULL, channel INTEGER NOT NULL, name TEXT, "
        "unit TEXT, type INTEGER, PRIMARY KEY (logger, channel))"
    )
    conn.execute("INSERT INTO channels VALUES ('L1', 1, 'Air', 'C', 1)")
    conn.commit()
    assert [c.decimals for c in web_store.channels(web_store.of_file(conn), "L1")] == [
        None
    ]  # read as it is
    conn.close()
    store = SqliteStore(path).open_sync()
    store.set_channels("L1", [(1, "Air", "C", 1)], {1: "0.1"})
    store.close_sync()
    conn = sqlite3.connect(path)
    assert conn.execute("SELECT name, format FROM channels").fetchall() == [("Air", "0.1")]


def test_format_decimals() -> None:
    assert [web_store.format_decimals(f) for f in ("0.1", "5.2", "0.0", "7.3", "")] == [
        1,
        2,
        0,
        3,
        0,
    ]

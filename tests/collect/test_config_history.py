"""The collector records each logger's configuration (issue 22): a real ``sondalog collect``
against a served logger whose settings a technician changes with writes over the logger's
line; the history rows, their diffs and the dashboard's log and logger page."""

from __future__ import annotations

import asyncio
import contextlib
import html
import re
import sqlite3
import urllib.request
from pathlib import Path
from typing import Any

from collector_run import collect_log, collecting, wait_for
from hypothesis import given, settings
from hypothesis import strategies as st
from served_logger import serving

from sondalog.app.virtual import VirtualLogger
from sondalog.client.ala1 import Ala1Client
from sondalog.client.station_grammar import LIMITS
from sondalog.client.station_logger import read_command
from sondalog.client.station_schema import instances
from sondalog.collect.config import SourceConfig
from sondalog.collect.config_watch import ConfigWatch, config_hash, diff_lines
from sondalog.collect.store_sqlite import SqliteStore


def history(store: Path) -> list[tuple[Any, ...]]:
    """(logger, old_hash, new_hash, diff) of every history row, oldest first."""
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(store, timeout=5)) as db,
    ):
        return db.execute(
            "SELECT logger, old_hash, new_hash, diff FROM config_history ORDER BY id"
        ).fetchall()
    return []


def config_events(store: Path) -> list[str]:
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(store, timeout=5)) as db,
    ):
        rows = db.execute("SELECT text FROM events WHERE kind = 'config' ORDER BY id")
        return [str(r[0]) for r in rows]
    return []


def unchanged(store: Path) -> int:
    """Contacts whose summary says the configuration was read and had not changed."""
    with contextlib.closing(sqlite3.connect(store, timeout=5)) as db:
        row = db.execute(
            "SELECT count(*) FROM events WHERE kind = 'download' "
            "AND text LIKE '%configuration unchanged%'"
        ).fetchone()
        return int(row[0])


def dashboard(config: Path) -> str:
    found = re.search(r"dashboard on (http://127\.0\.0\.1:\d+/)", collect_log(config))
    assert found, collect_log(config)
    return found.group(1)


def get(url: str) -> str:
    with urllib.request.urlopen(url, timeout=10) as answer:
        return str(answer.read().decode())


def test_a_technicians_write_is_stored_with_its_diff_and_shown(tmp_path: Path) -> None:
    with serving(tmp_path) as logger:
        config = tmp_path / "collector.toml"
        config.write_text(
            '[web]\nlisten = "127.0.0.1:0"\n\n'
            f'[[source]]\nurl = "{logger.url}"\nname = "weir"\ninterval = 0.5\ntimeout = 3\n'
        )
        store = tmp_path / "collector.sqlite"
        with collecting(config):
            wait_for(lambda: len(history(store)) == 1, 30, config, "the first configuration")
            ((serial, old, first, diff),) = history(store)
            assert (serial, old, diff) == ("000001", None, "")  # the initial one, no diff
            # a few contacts later nothing changed: still one row
            wait_for(lambda: unchanged(store) >= 2, 30, config, "contacts without change")
            assert len(history(store)) == 1
            # the technician, over the logger's line
            logger.ask("write channel 1 sampling period 000100", "write i name#<b>pump&1</b>#")
            wait_for(lambda: len(history(store)) == 2, 30, config, "the change")
            web = dashboard(config)
            log_page = get(web + "log")
            logger_page = get(web + "loggers/000001")
        _, old, new, diff = history(store)[1]
        assert old == first and new != first
        assert diff.splitlines() == [
            "i name: (empty) -> <b>pump&1</b>",
            "channel 1 sampling period: 000000 -> 000100",
        ]
        (changed,) = [e for e in config_events(store) if e.startswith("configuration changed")]
        assert changed.splitlines()[1:] == diff.splitlines()
    for page in (log_page, logger_page):
        assert "configuration changed" in page
        assert "channel 1 sampling period: 000000 -&gt; 000100" in page
        assert "&lt;b&gt;pump&amp;1&lt;/b&gt;" in page and "<b>pump" not in page
    assert html.escape(f"{first[:12]} → {new[:12]}", quote=False) in logger_page


def test_the_store_keeps_the_history_across_restarts(tmp_path: Path) -> None:
    """A restarted collector diffs against the stored configuration: a change made while it
    was stopped is one row with its diff, not a second 'first read'."""
    with serving(tmp_path) as logger:
        config = tmp_path / "collector.toml"
        config.write_text(
            "[web]\nenabled = false\n\n"
            f'[[source]]\nurl = "{logger.url}"\ninterval = 0.5\ntimeout = 3\n'
        )
        store = tmp_path / "collector.sqlite"
        with collecting(config):
            wait_for(lambda: len(history(store)) == 1, 30, config, "the first configuration")
        logger.ask("write device 2 type DS18B20")
        with collecting(config):
            wait_for(lambda: len(history(store)) == 2, 30, config, "the change")
        diff = history(store)[1][3].splitlines()
        assert diff == [
            "device 2 type: MSP430ADC -> DS18B20",
            "device 2 cal mult: 2.500000 -> 3276.800000",
        ]


def test_the_hash_is_of_a_canonical_form_and_the_diff_follows_the_file_order() -> None:
    """Whatever order the values come in, the same configuration has the same hash; the diff
    lists settings in the order of a station file (the manual's), each once."""
    virtual = VirtualLogger()
    wanted = instances(LIMITS["2.10"])
    values = {}
    for setting, n in wanted:
        answer = virtual.command(read_command(setting, n))
        values[setting.name(n)] = answer.split("\r\n")[0].strip()
    shuffled = dict(reversed(list(values.items())))
    assert config_hash(values, "2.10") == config_hash(shuffled, "2.10")
    assert config_hash(values, "2.10") != config_hash(values, "1.16")
    changed = {**values, "global timing": "64", "i name": "x", "channel 2 name": "Air[C]"}
    assert config_hash(changed, "2.10") != config_hash(values, "2.10")
    assert diff_lines(values, changed, "2.10") == [
        "i name: (empty) -> x",
        "channel 2 name: Supply[V] -> Air[C]",
        "global timing: 8 -> 64",
    ]


_NAMES = [setting.name(n) for setting, n in instances(LIMITS["1.16"])]


@given(
    st.dictionaries(
        st.sampled_from(_NAMES), st.text(st.characters(max_codepoint=255), max_size=8), max_size=20
    )
)
@settings(max_examples=200, deadline=None)
def test_a_change_shows_in_the_hash_and_the_diff_names_exactly_it(changes: dict[str, str]) -> None:
    base = dict.fromkeys(_NAMES, "0")
    after = {**base, **changes}
    differ = [name for name in _NAMES if after[name] != base[name]]
    lines = diff_lines(base, after, "1.16")
    assert [line.split(": ", 1)[0] for line in lines] == differ
    assert (config_hash(after, "1.16") == config_hash(base, "1.16")) == (not differ)


def test_config_every_reads_every_nth_contact(tmp_path: Path) -> None:
    """``config_every = 3``: contacts 1, 4, 7 read the configuration; 0 never does."""

    async def checks(url: str, every: int) -> list[bool]:
        store = SqliteStore(tmp_path / f"s{every}.sqlite").open_sync()
        watch = ConfigWatch(SourceConfig(name="s", url=url, config_every=every), store)
        done = []
        try:
            for _ in range(7):
                client = await Ala1Client.connect(url, timeout=5)
                try:
                    done.append(await watch.check(client) is not None)
                finally:
                    await client.close()
        finally:
            store.close_sync()
        return done

    with serving(tmp_path) as logger:
        every_third = asyncio.run(checks(logger.url, 3))
        never = asyncio.run(checks(logger.url, 0))
        every = asyncio.run(checks(logger.url, 1))
    assert every_third == [True, False, False, True, False, False, True]
    assert never == [False] * 7 and every == [True] * 7

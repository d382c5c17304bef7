"""SIGHUP to a real ``sondalog collect``: the file read again, its sources taken (issue 24).

Real loggers (``sondalog logger serve``), a real configuration file edited between signals:
an added source is stored, a removed one is contacted no more and its kept connection
closes, a changed one takes its new interval, and a bad file is one clear log line while the
running configuration goes on.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
import sqlite3
import tempfile
import time
from pathlib import Path
from typing import Any

from collector_run import collect_log, collecting, wait_for
from hypothesis import given, settings
from hypothesis import strategies as st
from served_logger import configure, sampling_logger, serving

from sondalog.collect.config import CollectorConfig, load_config
from sondalog.collect.reload import reloading, untaken


def _events(store: Path, source: str) -> int:
    with contextlib.closing(sqlite3.connect(store, timeout=5)) as db:
        row = db.execute(
            "SELECT count(*) FROM events WHERE source = ? AND kind = 'download'", (source,)
        ).fetchone()
        return int(row[0])


def _count(store: Path, source: str) -> int:
    with contextlib.suppress(sqlite3.OperationalError):
        return _events(store, source)
    return 0


def _readings(store: Path) -> int:
    with contextlib.closing(sqlite3.connect(store, timeout=5)) as db:
        return int(db.execute("SELECT count(*) FROM readings").fetchone()[0])


def _established(port: int) -> int:
    """Open TCP connections from or to the loopback ``port`` (both ends are counted)."""
    count = 0
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with contextlib.suppress(FileNotFoundError):
            for line in Path(table).read_text().splitlines()[1:]:
                fields = line.split()
                local, remote, state = fields[1], fields[2], fields[3]
                ports = {int(local.rsplit(":", 1)[1], 16), int(remote.rsplit(":", 1)[1], 16)}
                if state == "01" and port in ports:
                    count += 1
    return count


def _source(name: str, url: str, interval: float, extra: str = "") -> str:
    return f'[[source]]\nname = "{name}"\nurl = "{url}"\ninterval = {interval}\n{extra}\n'


def test_sighup_takes_the_new_source_list_and_keeps_it_on_a_bad_file(tmp_path: Path) -> None:
    store = tmp_path / "store.sqlite"
    config = tmp_path / "collector.toml"
    head = '[sqlite]\npath = "store.sqlite"\n\n[web]\nenabled = false\n\n'
    with (
        serving(tmp_path, name="a") as a,
        serving(tmp_path, name="b") as b,
        sampling_logger(tmp_path, 50) as d,
    ):
        configure(d)  # records readings; a and b record none
        config.write_text(
            head
            + _source("a", a.url, 0.3, "keep_open = true")
            + _source("b", b.url, 60, "keep_open = true")
        )
        with collecting(config) as proc:
            wait_for(lambda: _count(store, "a") >= 3, 30, config, "a's contacts")
            assert _count(store, "b") == 1  # every 60 s
            assert _readings(store) == 0
            assert _established(a.port) == 2  # a's connection is kept between its contacts
            config.write_text(
                head
                + _source("b", b.url, 0.3, "keep_open = true")  # changed: every 0.3 s
                + _source("c", d.url, 0.3)  # added
            )
            proc.send_signal(signal.SIGHUP)
            wait_for(
                lambda: _count(store, "c") >= 3 and _count(store, "b") >= 4,
                30,
                config,
                "the reloaded sources' contacts",
            )
            wait_for(lambda: _established(a.port) == 0, 10, config, "a's connection closed")
            removed = _count(store, "a")
            time.sleep(1.5)  # five of a's old intervals, and a write-behind flush
            assert _count(store, "a") == removed  # contacted no more
            assert "reloaded" in collect_log(config)
            assert "(1 added, 1 removed, 1 changed)" in collect_log(config)
            with contextlib.closing(sqlite3.connect(store, timeout=5)) as db:
                states = dict(db.execute("SELECT name, state FROM sources").fetchall())
            assert states["c"] == "ok" and states["b"] == "ok"
            assert _readings(store) > 0  # the added source's readings are stored

            good = config.read_text()
            before, after = good.rsplit("interval = 0.3", 1)  # c's
            config.write_text(before + "interval = -1" + after)
            line = config.read_text().splitlines().index("interval = -1") + 1
            proc.send_signal(signal.SIGHUP)
            wait_for(lambda: "reload refused" in collect_log(config), 30, config, "the refusal")
            refusal = next(t for t in collect_log(config).splitlines() if "reload refused" in t)
            assert f"{config}:{line}:" in refusal and "interval" in refusal, refusal
            seen = _count(store, "b"), _count(store, "c")
            wait_for(
                lambda: _count(store, "b") > seen[0] + 2 and _count(store, "c") > seen[1] + 2,
                30,
                config,
                "the old configuration going on",
            )
            assert proc.poll() is None
        assert proc.returncode == 0, collect_log(config)


def _state(store: Path, source: str) -> str | None:
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(store, timeout=5)) as db,
    ):
        row = db.execute("SELECT state FROM sources WHERE name = ?", (source,)).fetchone()
        return None if row is None else str(row[0])
    return None


def test_a_source_removed_mid_contact_is_not_left_contacting_and_a_stop_then_is_prompt(
    tmp_path: Path,
) -> None:
    """A logger that stops answering holds its contact (``contacting`` after a second);
    removed by a reload then, its state goes back to what it was, not ``contacting`` for
    good; SIGHUP and SIGTERM at once in that state: the process ends, cleanly and soon."""
    store = tmp_path / "store.sqlite"
    config = tmp_path / "collector.toml"
    head = '[sqlite]\npath = "store.sqlite"\n\n[web]\nenabled = false\n\n'
    with serving(tmp_path, name="a") as a, serving(tmp_path, name="b") as b:
        both = head + _source("a", a.url, 0.3, "timeout = 8") + _source("b", b.url, 0.3)
        only_b = head + _source("b", b.url, 0.3)
        config.write_text(both)
        with collecting(config) as proc:
            for round_ in range(2):
                wait_for(lambda: _state(store, "a") == "ok", 30, config, "a's good contact")
                a.proc.send_signal(signal.SIGSTOP)  # a's next contact waits (timeout 8 s)
                try:
                    wait_for(lambda: _state(store, "a") == "contacting", 15, config, "marked")
                    config.write_text(only_b)
                    proc.send_signal(signal.SIGHUP)
                    if round_ == 1:  # a stop while the reload waits for a's contact
                        proc.send_signal(signal.SIGTERM)
                        proc.wait(timeout=20)
                        break
                    wait_for(lambda: _state(store, "a") == "ok", 15, config, "a's state back")
                    seen = _count(store, "b")
                    going = lambda n=seen: _count(store, "b") > n + 2  # noqa: E731
                    wait_for(going, 15, config, "b going on")
                finally:
                    a.proc.send_signal(signal.SIGCONT)
                config.write_text(both)
                proc.send_signal(signal.SIGHUP)
        assert proc.returncode == 0, collect_log(config)
        assert _state(store, "a") == "ok"


class _Slow:
    """A collector whose reload takes a few turns of the loop, and says if two overlap."""

    def __init__(self, config: CollectorConfig, turns: list[int]) -> None:
        self.config = config
        self.sources: list[Any] = []
        self.turns = turns
        self.active = 0
        self.overlapped = False
        self.taken: list[int] = []

    async def reload(self, config: CollectorConfig) -> tuple[int, int, int]:
        self.active += 1
        self.overlapped |= self.active > 1
        for _ in range(self.turns[len(self.taken) % len(self.turns)]):
            await asyncio.sleep(0)
        self.config = config
        self.taken.append(len(config.sources))
        self.active -= 1
        return 0, 0, 0  # (added, removed, changed: only logged)


@settings(max_examples=40, deadline=None)
@given(
    steps=st.lists(st.tuples(st.integers(1, 4), st.integers(0, 5)), min_size=1, max_size=8),
    turns=st.lists(st.integers(0, 6), min_size=1, max_size=4),
)
def test_signals_during_a_reload_are_one_more_reload_never_two_at_once(
    steps: list[tuple[int, int]], turns: list[int]
) -> None:
    """Any interleaving of edits, signals and reloads: reloads never overlap, and the last
    file written is the one running once the signals stop (none is lost)."""
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "c.toml"

        def write(count: int) -> None:
            config.write_text(
                '[sqlite]\npath = "s.sqlite"\n\n'
                + "".join(_source(f"s{i}", f"tcp://127.0.0.1:{9000 + i}", 60) for i in range(count))
            )

        async def main() -> _Slow:
            write(1)
            collector = _Slow(load_config(config), turns)
            wake = asyncio.Event()
            task = asyncio.create_task(reloading(collector, config, wake))  # type: ignore[arg-type]
            for count, pause in steps:
                write(count)
                wake.set()
                for _ in range(pause):
                    await asyncio.sleep(0)
            for _ in range(200):
                await asyncio.sleep(0)
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            return collector

        collector = asyncio.run(main())
        assert not collector.overlapped
        assert collector.taken and collector.taken[-1] == steps[-1][0]
        assert len(collector.config.sources) == steps[-1][0]


def test_what_a_reload_does_not_take_is_named(tmp_path: Path) -> None:
    config = tmp_path / "c.toml"
    text = '[sqlite]\npath = "s.sqlite"\n\n' + _source("a", "tcp://127.0.0.1:9", 60)
    config.write_text(text)
    running = load_config(config)
    config.write_text('[web]\nlisten = "127.0.0.1:0"\n\n' + text.replace("s.sqlite", "t.sqlite"))
    assert untaken(running, load_config(config)) == ["[sqlite] path", "[buffer]", "[web]"]
    config.write_text(text.replace("60", "30"))
    assert untaken(running, load_config(config)) == []

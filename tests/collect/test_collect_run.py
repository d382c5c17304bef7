"""``sondalog collect`` as a real subprocess against served loggers and a served bus."""

from __future__ import annotations

import contextlib
import random
import select
import signal
import sqlite3
import subprocess
import time
from collections.abc import Iterator
from datetime import datetime, timedelta
from pathlib import Path

from served_logger import CLI, configure, sampling_logger

from sondalog.client.records import parse_row


def _expected(rows: list[str]) -> set[tuple[object, ...]]:
    out: set[tuple[object, ...]] = set()
    for line in rows:
        row = parse_row(line)
        for ch, value in enumerate(row.values, start=1):
            if value is not None:
                out.add(("000001", row.time.isoformat(), row.counter, ch, value))
    return out


def _stored(store: Path) -> list[tuple[object, ...]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        return db.execute(
            "SELECT logger, time, counter, channel, value FROM readings WHERE logger = '000001'"
        ).fetchall()


def _query(store: Path, sql: str) -> list[tuple[object, ...]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        return db.execute(sql).fetchall()


@contextlib.contextmanager
def _bus(tmp: Path) -> Iterator[str]:
    proc = subprocess.Popen(
        [*CLI, "bus", "serve", "--listen", "127.0.0.1:0", "--state", str(tmp / "bus")],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    )
    try:
        assert proc.stdout is not None
        assert select.select([proc.stdout], [], [], 15)[0]
        line = proc.stdout.readline().decode()
        assert line.startswith("listening on "), line
        yield "tcp://" + line.removeprefix("listening on ").strip()
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _collector(config: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [*CLI, "collect", str(config)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )


def _wait(condition: object, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with contextlib.suppress(sqlite3.OperationalError):
            if condition():  # type: ignore[operator]
                return
        time.sleep(0.1)
    raise AssertionError("timed out")


def test_logger_bus_and_an_offline_source(tmp_path: Path) -> None:
    store = tmp_path / "store.sqlite"
    with sampling_logger(tmp_path, 50) as served, _bus(tmp_path) as bus_url:
        configure(served)
        time.sleep(0.3)
        served.ask("write channel sampling period 000000 000000")
        rows = served.record()
        config = tmp_path / "collector.toml"
        config.write_text(
            f'[sqlite]\npath = "store.sqlite"\n\n'
            f'[[source]]\nurl = "{served.url}"\nname = "station"\ninterval = 0.5\n'
            f'timezone = "Europe/Prague"\n\n'
            f'[[source]]\nkind = "bus"\nurl = "{bus_url}"\nname = "bus"\ninterval = 0.5\n'
            f'modules = ["T1", "H1"]\nunits = {{ T1 = "°C", H1 = "%" }}\n\n'
            f'[[source]]\nurl = "tcp://127.0.0.1:9"\nname = "dead"\ninterval = 30\n'
            f"retry = 0.2\nretry_max = 1\n"
        )
        proc = _collector(config)
        try:
            _wait(
                lambda: (
                    len(_query(store, "SELECT * FROM events WHERE source = 'dead'")) >= 5
                    and _query(store, "SELECT state FROM sources WHERE name = 'station'")
                    == [("ok",)]
                    and len(_query(store, "SELECT * FROM readings WHERE logger = 'bus:H1'")) >= 1
                )
            )
        finally:
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
    assert sorted(_stored(store)) == sorted(_expected(rows))
    name, unit, utc, time_ = _query(
        store, "SELECT name, unit, utc, time FROM readings WHERE channel = 2 ORDER BY time LIMIT 1"
    )[0]
    assert (name, unit) == ("Level", "m")
    utc_time = datetime.fromisoformat(str(utc).replace("Z", "+00:00")).replace(tzinfo=None)
    assert utc_time == datetime.fromisoformat(str(time_)) - timedelta(hours=1)  # CET in March
    bus = _query(
        store, "SELECT logger, channel, name, unit, value FROM readings WHERE logger LIKE 'bus:%'"
    )
    assert {(b[0], b[2], b[3]) for b in bus} == {("bus:T1", "T1", "°C"), ("bus:H1", "H1", "%")}
    assert all(isinstance(b[4], float) for b in bus)
    state, error, logger, offset, fill = _query(
        store,
        "SELECT state, last_error, logger, offset_s, record_fill FROM sources WHERE name='station'",
    )[0]
    assert (state, error, logger) == ("ok", None, "000001") and isinstance(offset, float)
    assert fill.endswith("FILLING")
    dead = _query(store, "SELECT state, last_error FROM sources WHERE name = 'dead'")[0]
    assert dead[0] == "offline" and "ConnectionRefusedError" in dead[1]
    waits = [
        t.rsplit("retry in ", 1)[1]
        for (t,) in _query(store, "SELECT text FROM events WHERE source = 'dead'")
    ]
    assert waits[:5] == ["0.2 s", "0.4 s", "0.8 s", "1 s", "1 s"]  # exponential backoff, capped
    assert "source dead offline" in err.decode()
    downloads = _query(
        store, "SELECT text FROM events WHERE source = 'station' AND kind = 'download'"
    )
    assert downloads[0][0].startswith(f"logger 000001: {len(rows)} new rows")


def test_kill_9_at_any_moment_loses_nothing_and_stores_nothing_twice(tmp_path: Path) -> None:
    store = tmp_path / "store.sqlite"
    rng = random.Random(13)
    with sampling_logger(tmp_path, 100) as served:
        configure(served)
        config = tmp_path / "collector.toml"
        config.write_text(
            f'[sqlite]\npath = "store.sqlite"\n\n[[source]]\nurl = "{served.url}"\ninterval = 0.1\n'
        )
        counts = []
        for _ in range(4):
            proc = _collector(config)
            stored = len(_stored(store)) if store.exists() else 0
            _wait(lambda n=stored: len(_stored(store)) > n)  # it runs and stores ...
            time.sleep(rng.uniform(0.0, 0.5))  # ... and is killed at some moment
            proc.kill()
            proc.wait()
            assert proc.returncode == -signal.SIGKILL
            counts.append(len(_stored(store)))
        served.ask("write channel sampling period 000000 000000")
        rows = served.record()
        done = subprocess.run(
            [*CLI, "collect", "--once", str(config)], capture_output=True, timeout=60
        )
        assert done.returncode == 0, done.stderr
        config.write_text(config.read_text() + '\n[[source]]\nurl = "tcp://127.0.0.1:9"\n')
        failed = subprocess.run([*CLI, "collect", "--once", str(config)], capture_output=True)
        assert failed.returncode == 1, failed.stderr  # --once: a source failed
        assert b"sources failed: tcp://127.0.0.1:9" in failed.stderr
    assert counts == sorted(counts) and counts[-1] > counts[0] > 0
    stored = _stored(store)
    assert len(stored) == len(set(stored))
    assert set(stored) == _expected(rows)
    assert len(rows) > 200

"""``sondalog collect`` with ``[postgres]`` and ``[mqtt]`` against a served logger, a real
PostgreSQL and a real mosquitto: what the SQLite store holds reaches both, PostgreSQL even
when it was down during the first run (the batches wait in the disk buffer)."""

from __future__ import annotations

import asyncio
import contextlib
import json
import sqlite3
import subprocess
import time
from pathlib import Path

import psycopg
import services
from ha_rules import check_device_discovery, gather_messages
from served_logger import CLI, configure, sampling_logger

from sondalog.collect.buffer import DiskBuffer
from sondalog.collect.ha_discovery import Topics


def _sqlite(store: Path) -> set[tuple[object, ...]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        rows = db.execute("SELECT logger, time, counter, channel, value FROM readings").fetchall()
    return {tuple(r) for r in rows}


def _postgres(dsn: str) -> set[tuple[object, ...]]:
    with psycopg.connect(dsn) as c:
        rows = c.execute("SELECT logger, time, counter, channel, value FROM readings").fetchall()
    return {(lg, t.isoformat(timespec="seconds"), n, ch, v) for lg, t, n, ch, v in rows}


def _collect_once(config: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*CLI, "collect", "--once", str(config)], capture_output=True, text=True, timeout=60
    )


def test_collector_feeds_postgres_and_mqtt(
    tmp_path: Path,
    postgres: services.PostgresServer,
    pg_dsn: str,
    mosquitto: services.Mosquitto,
) -> None:
    with sampling_logger(tmp_path, 50) as served:
        configure(served)
        time.sleep(0.3)
        served.ask("write channel sampling period 000000 000000")
        config = tmp_path / "collector.toml"
        config.write_text(
            f'[sqlite]\npath = "store.sqlite"\n\n'
            f'[buffer]\npath = "buffer.sqlite"\n\n'
            f'[postgres]\ndsn = "{pg_dsn}"\nconnect_timeout = 2\n\n'
            f'[mqtt]\nurl = "{mosquitto.url}"\nclient_id = "e2e"\n\n'
            f'[[source]]\nurl = "{served.url}"\nname = "station"\ninterval = 1\n'
            'timezone = "Europe/Prague"\n'
        )
        postgres.stop()
        try:
            first = _collect_once(config)
        finally:
            postgres.start()
        assert first.returncode == 0, first.stderr
        stored = _sqlite(tmp_path / "store.sqlite")
        assert stored
        buffer = DiskBuffer(tmp_path / "buffer.sqlite")
        assert buffer.count("postgres") >= 1 and buffer.count("mqtt") == 0
        buffer.close()
        with psycopg.connect(pg_dsn) as c:  # nothing reached it (not even the schema)
            assert c.execute("SELECT to_regclass('readings')").fetchone() == (None,)

        second = _collect_once(config)  # PostgreSQL is back: the buffer is replayed
        assert second.returncode == 0, second.stderr
    assert _postgres(pg_dsn) == _sqlite(tmp_path / "store.sqlite") == stored
    buffer = DiskBuffer(tmp_path / "buffer.sqlite")
    assert buffer.count("postgres") == 0

    topics = Topics(client_id="e2e")
    msgs = asyncio.run(gather_messages(mosquitto.port, ["homeassistant/#", "sondalog/#"]))
    by_topic = {str(m.topic): m.payload for m in msgs}
    payload = json.loads(by_topic[topics.config("000001")])  # type: ignore[arg-type]
    check_device_discovery(topics.config("000001"), payload, topics)
    cmps = payload["cmps"]
    assert cmps["ch2"]["name"] == "Level" and cmps["ch2"]["unit_of_measurement"] == "m"
    last_time, last_value = max((r[1], r[4]) for r in stored if r[3] == 2)
    state = json.loads(by_topic[cmps["ch2"]["state_topic"]])  # type: ignore[arg-type]
    assert (state["time"], state["value"]) == (last_time, last_value)
    with contextlib.closing(sqlite3.connect(tmp_path / "store.sqlite")) as db:
        (utc,) = db.execute(
            "SELECT utc FROM readings WHERE channel = 2 AND time = ?", (last_time,)
        ).fetchone()
    assert state["utc"] == utc and utc.endswith("Z")  # one spelling in SQLite and MQTT
    # --once is for cron: Home Assistant must not mark every entity unavailable between runs
    assert by_topic[topics.availability] == b"online"

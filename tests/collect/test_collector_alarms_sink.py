"""The collector's own alarms on a real PostgreSQL outage (issue 21): ``sondalog collect``
with a ``[postgres]`` sink whose server is stopped raises ``watch = "sink"`` after its
``after`` and ``watch = "buffer"`` when more than ``above`` batches wait in the disk buffer;
when the server is back the buffer drains, both clear, and every reading reaches
PostgreSQL."""

from __future__ import annotations

import contextlib
import sqlite3
from pathlib import Path

import psycopg
import services
from collector_run import cli, collect_log, collecting, events, states, wait_for
from served_logger import configure, sampling_logger

from sondalog.collect.alarms import alarm_id

DOWN, BACKLOG = "pg down", "pg backlog"
RULES = f"""[[notify]]
name = "log"
kind = "log"

[[alarm]]
kind = "collector"
name = "{DOWN}"
watch = "sink"
sink = "postgres"
after = "2s"
notify = ["log"]

[[alarm]]
kind = "collector"
name = "{BACKLOG}"
watch = "buffer"
sink = "post*"
above = 3
notify = ["log"]
"""


def _config(tmp: Path, url: str, dsn: str) -> Path:
    path = tmp / "collector.toml"
    path.write_text(
        '[sqlite]\npath = "store.sqlite"\n\n[buffer]\npath = "buffer.sqlite"\n\n'
        f'[postgres]\ndsn = "{dsn}"\nconnect_timeout = 1\n\n[web]\nenabled = false\n\n'
        f'[[source]]\nurl = "{url}"\nname = "station"\ninterval = 0.3\ntimeout = 2\n\n' + RULES
    )
    return path


def _waiting(buffer: Path) -> int:
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(buffer, timeout=5)) as db,
    ):
        row = db.execute("SELECT count(*) FROM pending WHERE sink = 'postgres'").fetchone()
        return int(row[0])
    return 0


def _readings(store: Path) -> set[tuple[object, ...]]:
    with (
        contextlib.suppress(sqlite3.OperationalError),  # not created yet
        contextlib.closing(sqlite3.connect(store, timeout=5)) as db,
    ):
        rows = db.execute("SELECT logger, time, counter, channel, value FROM readings")
        return {tuple(r) for r in rows.fetchall()}
    return set()


def _pg_readings(dsn: str) -> set[tuple[object, ...]]:
    with psycopg.connect(dsn) as c:
        rows = c.execute("SELECT logger, time, counter, channel, value FROM readings").fetchall()
    return {(lg, t.isoformat(timespec="seconds"), n, ch, v) for lg, t, n, ch, v in rows}


def test_sink_down_and_buffer_growing_raise_and_clear_when_postgres_is_back(
    tmp_path: Path, postgres: services.PostgresServer, pg_dsn: str
) -> None:
    store, buffer = tmp_path / "store.sqlite", tmp_path / "buffer.sqlite"
    down, backlog = (DOWN, "postgres"), (BACKLOG, "postgres")
    with sampling_logger(tmp_path, 5) as served:
        configure(served)
        config = _config(tmp_path, served.url, pg_dsn)
        postgres.stop()
        try:
            with collecting(config):
                wait_for(lambda: _readings(store) != set(), 20, config, "readings")
                wait_for(lambda: states(store).get(down) == "raised", 20, config, "sink alarm")
                (_, _, after), *_ = events(store, DOWN)
                assert after == 2.0  # raised when it had been down for its `after`
                assert _waiting(buffer) >= 1  # the readings wait in the buffer
                wait_for(lambda: states(store).get(backlog) == "raised", 20, config, "backlog")
                assert _waiting(buffer) > 3
                (_, _, value), *_ = [e for e in events(store, BACKLOG) if e[0] == "raised"]
                assert value == 4  # raised by the first count above 3
                listed = cli("alarms", "list", str(config)).stdout
                for rule in (DOWN, BACKLOG):
                    line = next(x for x in listed.splitlines() if rule in x)
                    assert " raised " in line and alarm_id(rule, "postgres") in line
                postgres.start()
                wait_for(
                    lambda: states(store).get(down) == states(store).get(backlog) == "cleared",
                    30,
                    config,
                    "both alarms cleared",
                )
        finally:
            with contextlib.suppress(Exception):
                postgres.start()  # the session's server stays up for the other tests
    assert _waiting(buffer) == 0  # drained (a batch being delivered passes through it)
    assert [w for w, _, _ in events(store, DOWN)] == ["raised", "cleared"]
    assert [w for w, _, _ in events(store, BACKLOG)] == ["raised", "cleared"]
    log = collect_log(config)
    assert "alarm RAISED" in log and "alarm CLEARED" in log  # the log destination
    stored = _readings(store)
    assert stored and _pg_readings(pg_dsn) == stored  # nothing lost

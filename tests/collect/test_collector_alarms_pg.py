"""Two collectors share their alarms on one PostgreSQL (issue 21), for real: two
``sondalog collect`` processes, each with its own SQLite store, download the same served
logger with the same threshold rule and ``[postgres] alarms = true``; a real aiosmtpd gets
exactly one e-mail per event (raised, cleared) although both collectors see it, and an
acknowledgement asked with ``sondalog alarms ack`` reaches both."""

from __future__ import annotations

import contextlib
import signal
import sqlite3
import subprocess
import time
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import psycopg
from alarm_mail import smtp_server
from served_logger import CLI, serving

from sondalog.collect.alarms import alarm_id

RULE = "level high"
SUBJECT = "000001/2"


def _config(folder: Path, url: str, smtp: int, dsn: str) -> Path:
    folder.mkdir()
    path = folder / "collector.toml"
    path.write_text(
        '[sqlite]\npath = "store.sqlite"\n\n[web]\nenabled = false\n\n'
        f'[postgres]\ndsn = "{dsn}"\nalarms = true\n\n'
        f'[[source]]\nurl = "{url}"\nname = "station"\ninterval = 0.5\ntimeout = 1\n'
        "retry = 0.3\nretry_max = 0.5\n\n"
        f'[[notify]]\nname = "mail"\nkind = "email"\nsmtp = "127.0.0.1:{smtp}"\n'
        'from = "collector@example.net"\nto = ["ops@example.net"]\nbackoff = "0.5s"\n\n'
        f'[[alarm]]\nkind = "threshold"\nname = "{RULE}"\nchannel = "Level"\n'
        'above = 1.8\nclear = 1.2\nnotify = ["mail"]\n'
    )
    return path


@contextlib.contextmanager
def _collecting(config: Path) -> Iterator[subprocess.Popen[bytes]]:
    proc = subprocess.Popen(
        [*CLI, "collect", str(config)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        try:
            proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()


def _wait_contact(store: Path, timeout: float = 60) -> None:
    """Until the collector of ``store`` has contacted its logger: it is up, its alarm states
    loaded from the server (a collector slow to start under load would otherwise load the
    other one's raise, and not see it itself)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with (
            contextlib.suppress(sqlite3.Error),
            contextlib.closing(sqlite3.connect(f"{store.as_uri()}?mode=ro", uri=True)) as db,
        ):
            if db.execute("SELECT 1 FROM sources WHERE last_contact IS NOT NULL").fetchone():
                return
        time.sleep(0.2)
    raise AssertionError(f"no contact in {store}")


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=60)


def _stderr(proc: subprocess.Popen[bytes]) -> str:
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    return err.decode(errors="replace")


def test_two_collectors_on_one_postgres_mail_once_per_event(tmp_path: Path, pg_dsn: str) -> None:
    site = tmp_path / "site.toml"
    site.write_text(  # input 16 goes high after 3 s; input 17 stays low
        "[logger]\n[[logger.analog]]\naddress = 16\n"
        'signal = { model = "steps", schedule = [[0, 1.0], [3, 2.0]] }\n'
        '[[logger.analog]]\naddress = 17\nsignal = { model = "constant", value = 1.0 }\n'
    )
    ident = alarm_id(RULE, SUBJECT)
    with serving(tmp_path, "--site", str(site)) as served, smtp_server() as mail:
        configs = [_config(tmp_path / n, served.url, mail.port, pg_dsn) for n in ("a", "b")]
        with _collecting(configs[0]) as one, _collecting(configs[1]) as two:
            for config in configs:  # both running (their alarms loaded) before the level rises
                _wait_contact(config.parent / "store.sqlite")
            served.ask(
                "write date " + datetime.now(UTC).strftime("%Y%m%d%H%M%S"),
                "write channel max number 2",
                "write channel 2 type 3 write channel 2 address 16 write channel 2 switch output 0",
                "write channel 2 name/Level[m]/ write channel 2 format 0.3",
                "write channel 1 record change 0 write channel 2 record change 0",
                "write channel sampling period 000001 000001",
            )
            mail.wait(lambda: len(mail.mails) >= 1, 30)
            time.sleep(3)  # both collectors have read the rows that raised it
            listed = _cli("alarms", "list", str(configs[1]))
            assert listed.returncode == 0 and f"{ident}  raised" in listed.stdout, listed
            acked = _cli("alarms", "ack", str(configs[0]), ident)
            assert acked.returncode == 0, acked.stderr
            time.sleep(2)  # both collectors take the acknowledgement on their next turn
            served.ask("write channel 2 address 17")  # the level falls
            mail.wait(lambda: len(mail.mails) >= 2, 30)
            time.sleep(3)
            errors = [_stderr(one), _stderr(two)]
        keys = mail.sent_keys()
        assert [k.split("/")[1] for k in keys] == ["raised", "cleared"], mail.subjects()
        for err in errors:  # each collector saw both events itself
            for what in ("raised", "acknowledged", "cleared"):
                assert f"alarm {what} {ident}" in err, err
        for config in configs:  # each collector's own store holds no alarm table
            with contextlib.closing(sqlite3.connect(config.parent / "store.sqlite")) as db:
                tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master")}
            assert "readings" in tables and "alarm_outbox" not in tables
        with psycopg.connect(pg_dsn) as db:
            rows = db.execute("SELECT what, state FROM alarm_outbox ORDER BY created").fetchall()
            events = db.execute("SELECT what FROM alarm_events ORDER BY time").fetchall()
        assert rows == [("raised", "sent"), ("cleared", "sent")]
        assert events == [("raised",), ("acknowledged",), ("cleared",)]

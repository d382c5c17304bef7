"""Three collectors share six loggers through one PostgreSQL (issue 24), for real.

A served fleet of six virtual loggers records a row a second; a ``sondalog collect`` with a
``[cluster]`` table takes them all, and two more with the same file content (each its own
SQLite store) started beside it make the three split them two each. One is killed with
SIGKILL: its loggers are contacted again by the others within two intervals. Then the
survivors stop, a last ``collect --once`` catches up, and PostgreSQL holds every row each
logger recorded, once, and nothing else; the threshold alarm every logger's supply raises
was recorded and queued once per logger, and no collector raised ``no_contact`` for the
loggers it did not hold. Rows were downloaded by two collectors only around a handover:
the download's cursor travels with the lease.
"""

from __future__ import annotations

import contextlib
import itertools
import select
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import psycopg
from collector_run import collecting
from served_logger import CLI

from sondalog.client import Client

LOGGERS = 6
INTERVAL = 4.0
LEASE = 1.5


@contextlib.contextmanager
def fleet(tmp: Path) -> Iterator[dict[str, str]]:
    """Six served loggers F01..F06 sampling their supply every second: serial -> URL."""
    site = tmp / "fleet.toml"
    site.write_text(
        f'[[loggers]]\ncount = {LOGGERS}\nserial_number = "F{{n:02}}"\nlisten = "127.0.0.1:0"\n'
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(tmp / "state")],
        stdout=subprocess.PIPE,
        bufsize=0,  # (select sees each line: a burst of them is not buffered away)
        stderr=(tmp / "fleet.log").open("ab"),
    )
    urls: dict[str, str] = {}
    try:
        assert proc.stdout is not None
        while len(urls) < LOGGERS:
            ready, _, _ = select.select([proc.stdout], [], [], 60)
            assert ready, (tmp / "fleet.log").read_text()
            words = proc.stdout.readline().decode().split()
            assert words[:1] == ["logger"], words
            urls[words[1]] = "tcp://" + words[-1]
        now = datetime.now(UTC).strftime("%Y%m%d%H%M%S")
        for url in urls.values():
            ask(url, f"write date {now}", "write channel max number 1")
            ask(url, "write channel 1 record change 0", "write channel sampling period 000001")
        yield urls
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def ask(url: str, *commands: str) -> list[str]:
    out: list[str] = []
    with Client(url) as client:
        for command in commands:
            answer = client.command(command, timeout=10)
            assert answer.ok, (command, answer)
            out.extend(answer.lines)
    return out


def record_keys(url: str) -> set[tuple[str, int]]:
    """Every row of the logger's record as (stamp, counter)."""
    keys = set()
    for line in ask(url, "read record 1000000 from start"):
        stamp = line.split(",")[0]
        day, _, counter = stamp.partition(".")
        keys.add((datetime.strptime(day, "%Y%m%d%H%M%S").isoformat(), int(counter or 0)))
    return keys


def config(folder: Path, urls: dict[str, str], dsn: str) -> Path:
    folder.mkdir()
    sources = "".join(
        f'[[source]]\nurl = "{url}"\nname = "{serial}"\ninterval = {INTERVAL}\n'
        "timeout = 2\nretry = 0.5\nretry_max = 1\n\n"
        for serial, url in sorted(urls.items())
    )
    path = folder / "collector.toml"
    path.write_text(
        '[sqlite]\npath = "store.sqlite"\n\n[web]\nenabled = false\n\n'
        f'[postgres]\ndsn = "{dsn}"\nalarms = true\n\n[cluster]\nlease = {LEASE}\n\n'
        f"{sources}"
        '[[notify]]\nname = "log"\nkind = "log"\n\n'
        '[[alarm]]\nkind = "threshold"\nname = "supply high"\nchannel = 1\nabove = 5\n'
        'notify = ["log"]\n\n'
        '[[alarm]]\nkind = "no_contact"\nname = "silent"\nafter = "12s"\nnotify = ["log"]\n'
    )
    return path


def holders(dsn: str) -> dict[str, tuple[str | None, float | None]]:
    """source -> (holder, last contact)."""
    with psycopg.connect(dsn) as db:
        try:
            rows = db.execute("SELECT source, holder, last_contact FROM collector_leases")
        except psycopg.errors.UndefinedTable:  # no collector has started yet
            return {}
        return {str(s): (h, c) for s, h, c in rows.fetchall()}


def pid_of(holder: str | None) -> int | None:
    return None if holder is None else int(holder.split(":")[-2])


def twice(files: list[Path]) -> int:
    """How many rows were downloaded by more than one collector (their SQLite stores)."""
    seen: dict[tuple[str, str, int], int] = {}
    for path in files:
        with contextlib.closing(sqlite3.connect(path.parent / "store.sqlite")) as db:
            for key in db.execute("SELECT logger, time, counter FROM readings"):
                seen[key] = seen.get(key, 0) + 1
    return sum(n - 1 for n in seen.values())


def wait_until(what: str, condition: object, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while not condition():  # type: ignore[operator]
        assert time.monotonic() < deadline, f"timed out: {what}: {condition.__doc__}"
        time.sleep(0.2)


def test_three_collectors_share_six_loggers_and_survive_a_kill(tmp_path: Path, pg_dsn: str) -> None:
    with fleet(tmp_path) as urls:
        files = [config(tmp_path / name, urls, pg_dsn) for name in ("a", "b", "c")]
        with contextlib.ExitStack() as running:
            a = running.enter_context(collecting(files[0]))

            def alone() -> bool:  # the first collector takes every logger
                table = holders(pg_dsn)
                return len(table) == LOGGERS and {pid_of(h) for h, _ in table.values()} == {a.pid}

            wait_until("the first collector holding all", alone, 60)
            b, c = (running.enter_context(collecting(f)) for f in files[1:])
            procs = {p.pid: p for p in (a, b, c)}

            def balanced() -> bool:  # adding two spreads them
                table = holders(pg_dsn)
                counts = [sum(1 for h, _ in table.values() if pid_of(h) == pid) for pid in procs]
                balanced.__doc__ = f"{counts} {table}"
                return len(table) == LOGGERS and counts == [2, 2, 2]

            wait_until("two loggers each", balanced, 60)
            victim = pid_of(holders(pg_dsn)["F01"][0])
            assert victim is not None
            seen: dict[str, list[float]] = {s: [] for s in urls}
            killed_at = time.monotonic()
            procs[victim].send_signal(signal.SIGKILL)
            procs[victim].wait()
            with psycopg.connect(pg_dsn, autocommit=True) as db:
                db_killed = db.execute("SELECT extract(epoch from clock_timestamp())").fetchone()
                while time.monotonic() < killed_at + 5 * INTERVAL:
                    rows = db.execute(
                        "SELECT source, holder, last_contact FROM collector_leases"
                    ).fetchall()
                    for source, holder, contact in rows:
                        assert pid_of(holder) != victim or time.monotonic() < killed_at + INTERVAL
                        if contact is not None and contact not in seen[source]:
                            seen[source].append(contact)
                    time.sleep(0.1)
            assert db_killed is not None
            for source, contacts in seen.items():  # polled on, within two intervals
                before = [c for c in contacts if c <= db_killed[0]]  # its last contact
                times = [max(before, default=float(db_killed[0]))]
                times += [c for c in contacts if c > db_killed[0]] + [time.time()]
                gaps = [b - a for a, b in itertools.pairwise(times)]
                assert len(contacts) >= 3 and max(gaps) <= 2 * INTERVAL, (source, times)
            held = holders(pg_dsn)
            assert {pid_of(h) for h, _ in held.values()} == set(procs) - {victim}
        survivors_logs = [(f.parent / "collect.log").read_text() for f in files]
        expected = {serial: record_keys(url) for serial, url in urls.items()}
        last = subprocess.run(
            [*CLI, "collect", "--once", str(files[0])], capture_output=True, timeout=120
        )
        assert last.returncode == 0, last.stderr.decode()
        recorded = {serial: record_keys(url) for serial, url in urls.items()}
    with psycopg.connect(pg_dsn) as db:
        stored = db.execute(
            "SELECT logger, time, counter, count(*) FROM readings GROUP BY 1, 2, 3"
        ).fetchall()
        raised = db.execute(
            "SELECT rule, subject, what FROM alarm_events ORDER BY subject"
        ).fetchall()
        queued = db.execute("SELECT count(*) FROM alarm_outbox WHERE what = 'raised'").fetchone()
        leases = db.execute("SELECT count(*) FROM collector_leases WHERE holder IS NOT NULL")
        still_held = leases.fetchone()
    rows: dict[str, set[tuple[str, int]]] = {s: set() for s in urls}
    for logger, stamp, counter, copies in stored:
        assert copies == 1  # one reading a row: channel 1
        rows[logger].add((stamp.isoformat(), counter))
    for serial in urls:  # every row recorded before the last run is stored, nothing else
        assert expected[serial] <= rows[serial] <= recorded[serial], serial
    assert raised == [("supply high", f"F0{n}/1", "raised") for n in range(1, 7)], raised
    assert queued == (LOGGERS,)
    assert still_held == (0,)  # the last run gave its leases back
    # resume points are shared: a row is downloaded again only after a handover in the
    # middle of a contact (a batch stored, its cursor not saved yet), not from the start
    assert twice(files) <= 3 * LOGGERS, twice(files)
    for text in survivors_logs:
        assert "Traceback" not in text, text

"""State is private (issue 20): every directory sondalog keeps state in is 0700 and every file
in it 0600, whatever the umask (docs/security.md). Served for real: ``sondalog serve`` of the
GSM example world with a bus and a fleet added (logger store, fleet store, EEPROM store,
``network.json``, the modem trace, Maildirs with a delivered message), and the collector's
store and disk buffer."""

from __future__ import annotations

import os
import re
import select
import signal
import smtplib
import sqlite3
import stat
import subprocess
import sys
from collections.abc import Iterator
from datetime import datetime
from email.message import EmailMessage
from pathlib import Path

import pytest

from sondalog.collect.buffer import DiskBuffer
from sondalog.collect.model import Reading
from sondalog.collect.store_sqlite import SqliteStore
from sondalog.io.mail.maildirs import MaildirAccounts
from sondalog.io.private import connect_private, open_private, private_dir, private_parents

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(params=[0o022, 0o000], ids=["umask022", "umask000"])
def umask(request: pytest.FixtureRequest) -> Iterator[int]:
    """The process umask set for the test (a served child inherits it), restored after."""
    old = os.umask(request.param)
    try:
        yield request.param
    finally:
        os.umask(old)


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.lstat().st_mode)


def assert_private(root: Path) -> set[str]:
    """Every directory under ``root`` (itself included) is 0700, every file 0600; returns
    the files found, relative to ``root``."""
    assert _mode(root) == 0o700, f"{root}: {oct(_mode(root))}"
    files: set[str] = set()
    for folder, dirs, names in os.walk(root):
        for name in dirs:
            path = Path(folder, name)
            assert _mode(path) == 0o700, f"{path}: {oct(_mode(path))}"
        for name in names:
            path = Path(folder, name)
            assert _mode(path) == 0o600, f"{path}: {oct(_mode(path))}"
            files.add(str(path.relative_to(root)))
    return files


# -- the helpers ----------------------------------------------------------------------------
def test_private_dir_and_files(tmp_path: Path, umask: int) -> None:
    before = _mode(tmp_path)
    state = private_dir(tmp_path / "a" / "b" / "state")
    assert _mode(tmp_path) == before  # an existing parent is not ours to change
    with open_private(state / "x.json") as file:
        file.write("{}")
    with open_private(state / "trace", "a") as file:
        file.write("one\n")
    with open_private(state / "trace", "a") as file:
        file.write("two\n")
    assert (state / "trace").read_text() == "one\ntwo\n"
    db = connect_private(state / "db.sqlite")
    db.execute("PRAGMA journal_mode=WAL")
    db.execute("CREATE TABLE t (x)")
    db.execute("INSERT INTO t VALUES (1)")
    db.commit()
    try:
        files = assert_private(tmp_path / "a")
    finally:
        db.close()
    assert {"b/state/db.sqlite-wal", "b/state/db.sqlite-shm", "b/state/trace"} <= files
    private_parents(tmp_path / "c" / "d" / "out.sqlite")
    assert _mode(tmp_path / "c") == _mode(tmp_path / "c" / "d") == 0o700


def test_state_left_world_readable_is_made_private(tmp_path: Path, umask: int) -> None:
    """State made by an older version (0755, 0644) is tightened when it is opened again."""
    state = tmp_path / "state"
    state.mkdir()
    os.chmod(state, 0o755)
    with sqlite3.connect(state / "ala1.sqlite") as db:
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("CREATE TABLE t (x)")
    for path in state.iterdir():
        os.chmod(path, 0o644)
    private_dir(state)
    connect_private(state / "ala1.sqlite").close()
    assert "ala1.sqlite" in assert_private(state)


def test_maildir_messages_are_private(tmp_path: Path, umask: int) -> None:
    accounts = MaildirAccounts(tmp_path / "mail", {"a@example.net": "pw"})
    accounts.create_all()
    key = accounts.deliver("a@example.net", b"Subject: hi\r\n\r\nsecret\r\n")
    accounts.deliver("a@example.net", b"Subject: 2\r\n\r\nx\r\n")
    files = assert_private(tmp_path / "mail")
    assert f"a@example.net/new/{key}" in files and len(files) == 2


# -- the collector's store and buffer ----------------------------------------------------------
def test_collector_store_and_buffer_are_private(tmp_path: Path, umask: int) -> None:
    state = tmp_path / "state" / "collector"  # missing: made 0700
    reading = Reading("L1", 1, datetime(2024, 5, 1, 12, 0), 7, 1, 21.5, None, "t", "C")
    store = SqliteStore(state / "collector.sqlite").open_sync()
    buffer = DiskBuffer(state / "collector.buffer.sqlite")
    try:
        store.add_source("L1", "tcp://127.0.0.1:1", "ala1")
        buffer.append("postgres", [reading])
        files = assert_private(tmp_path / "state")
    finally:
        buffer.close()
        store.close_sync()
    assert {
        "collector/collector.sqlite",
        "collector/collector.sqlite-wal",
        "collector/collector.buffer.sqlite",
        "collector/collector.buffer.sqlite-wal",
    } <= files


# -- sondalog serve: logger, fleet, bus, mail hub, GSM network -------------------------------------
def _site(tmp_path: Path) -> Path:
    """The GSM example world (logger, modem with its trace, mail hub) plus the example bus
    and a fleet of two loggers, all on free ports."""
    text = (EXAMPLES / "gsm-site.toml").read_text()
    bus = (EXAMPLES / "site.toml").read_text().split("[bus]", 1)[1].split("[mail]", 1)[0]
    text += "\n[bus]" + bus
    text += '\n[[loggers]]\ncount = 2\nserial_number = "F{n:04}"\nlisten = "127.0.0.1:0"\n'
    text = re.sub(r'(listen|smtp|pop3|api) = "127\.0\.0\.1:\d+"', r'\1 = "127.0.0.1:0"', text)
    text = text.replace('publish = { "10001" = 20001 }', "")
    site = tmp_path / "site.toml"
    site.write_text(text)
    return site


def _announced(proc: subprocess.Popen[bytes], last: str) -> list[str]:
    assert proc.stdout is not None
    lines: list[str] = []
    while not any(line.startswith(last) for line in lines):
        ready, _, _ = select.select([proc.stdout], [], [], 30)
        line = proc.stdout.readline().decode() if ready else ""
        if not line:
            proc.kill()
            _, err = proc.communicate()
            raise AssertionError(f"serve printed only {lines}: {err.decode()}")
        lines.append(line.strip())
    return lines


def test_served_state_is_private(tmp_path: Path, umask: int) -> None:
    state = tmp_path / "state"
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(_site(tmp_path)), "--state", str(state)],
        stdout=subprocess.PIPE,
        bufsize=0,  # (select sees each line: a burst of them is not buffered away)
        stderr=subprocess.PIPE,
    )
    try:
        lines = _announced(proc, "logger com line joined")
        smtp_port = int(re.findall(r":(\d+)", next(x for x in lines if "mail SMTP" in x))[0])
        message = EmailMessage()
        message["From"], message["To"], message["Subject"] = "u@x", "user@example.net", "hi"
        message.set_content("password: secret")
        with smtplib.SMTP("127.0.0.1", smtp_port, timeout=10) as smtp:
            smtp.send_message(message)
        running = assert_private(state)  # while open: the -wal and -shm files are there
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(15) == 0
    stopped = assert_private(state)
    expected = {
        "logger/ala1.sqlite",
        "logger/ala1.sqlite-wal",
        "logger/ala1.sqlite-shm",
        "logger/identity.json",
        "loggers/fleet.sqlite",
        "loggers/fleet.sqlite-wal",
        "loggers/F0001/identity.json",
        "bus/hctmps1-eeprom.sqlite3",
        "gsm/network.json",
        "gsm/modem.trace",
    }
    assert expected <= running, sorted(running)
    assert any(name.startswith("mail/user@example.net/new/") for name in running)
    assert {"logger/ala1.sqlite", "gsm/network.json"} <= stopped

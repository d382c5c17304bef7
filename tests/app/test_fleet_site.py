"""``[[loggers]]`` in a site file (issue 11): loggers declared one by one or as a numbered
range, errors that name file, line and field; a served fleet with group commit."""

from __future__ import annotations

import logging
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from sondalog.ala1 import Engine, Identity
from sondalog.app.site import load_site
from sondalog.backends.sim.logger import default_hardware
from sondalog.backends.store.ala1_nv import NvDatabase
from sondalog.config import ConfigError

T0 = 1_000_000_000.0


def _write(tmp_path: Path, text: str) -> Path:
    site = tmp_path / "fleet.toml"
    site.write_text(text)
    return site


def test_declared_and_numbered_loggers(tmp_path: Path) -> None:
    (tmp_path / "world.toml").write_text(
        '[logger]\nsupply = { model = "constant", value = 12.5 }\n'
    )
    site = _write(
        tmp_path,
        '[[loggers]]\nserial_number = "A1-0001"\nlisten = "127.0.0.1:11001"\n'
        'protocol = "1.16"\nsite = "world.toml"\n\n'
        '[[loggers]]\ncount = 3\nfirst = 9\nserial_number = "F{n:04}"\n'
        'listen = "127.0.0.1:12000"\n',
    )
    plan = load_site(site)
    assert [(m.serial_number, m.listen[1]) for m in plan.fleet] == [
        ("A1-0001", 11001),
        ("F0009", 12000),
        ("F0010", 12001),
        ("F0011", 12002),
    ]
    assert plan.fleet[0].protocol == "1.16" and plan.fleet[0].world == tmp_path / "world.toml"
    assert plan.logger is None and plan.fleet[1].world is None
    assert ("loggers[1].listen", ("127.0.0.1", 12002)) in plan.listens


@pytest.mark.parametrize(
    ("body", "field", "line", "message"),
    [
        ('[[loggers]]\nserial_number = "A"\n', "loggers[0].listen", 1, "required"),
        (
            '[[loggers]]\nserial_number = "A"\nlisten = "127.0.0.1:1"\ncolor = 1\n',
            "loggers[0].color",
            4,
            "unknown table or key 'color'",
        ),
        (
            '[[loggers]]\nserial_number = "A"\nlisten = "127.0.0.1:1"\n\n'
            '[[loggers]]\ncount = 2\nserial_number = "B"\nlisten = "127.0.0.1:5"\n',
            "loggers[1].serial_number",
            7,
            "needs {n}",
        ),
        (
            '[[loggers]]\ncount = 0\nserial_number = "B{n}"\nlisten = "127.0.0.1:5"\n',
            "loggers[0].count",
            2,
            "integer from 1",
        ),
        (
            '[[loggers]]\ncount = 2\nserial_number = "B{n}"\nlisten = "127.0.0.1:65535"\n',
            "loggers[0].listen",
            4,
            "beyond 65535",
        ),
        (
            '[[loggers]]\nserial_number = "A/1"\nlisten = "127.0.0.1:1"\n',
            "loggers[0].serial_number",
            2,
            "names a directory",
        ),
        (
            '[[loggers]]\nserial_number = "B2"\nlisten = "127.0.0.1:1"\n\n'
            '[[loggers]]\ncount = 3\nserial_number = "B{n}"\nlisten = "127.0.0.1:7"\n',
            "loggers[1].serial_number",
            7,
            "B2 is also declared by loggers[0]",
        ),
        (
            '[[loggers]]\nserial_number = "A"\nlisten = "127.0.0.1:8"\n\n'
            '[[loggers]]\ncount = 3\nserial_number = "B{n}"\nlisten = "127.0.0.1:6"\n',
            "loggers[1].listen",
            8,
            "port 8 is already used by loggers[0]",
        ),
        (
            '[[loggers]]\nserial_number = "A{n}{x}"\ncount = 2\nlisten = "127.0.0.1:1"\n',
            "loggers[0].serial_number",
            2,
            "use {n}",
        ),
        ('[[loggers]]\nserial_number = "A"\nlisten = "nowhere"\n', "loggers[0].listen", 3, ""),
        ("loggers = 3\n", "loggers", 1, "array of tables"),
    ],
)
def test_errors_name_file_line_and_field(
    tmp_path: Path, body: str, field: str, line: int, message: str
) -> None:
    site = _write(tmp_path, body)
    with pytest.raises(ConfigError) as caught:
        load_site(site)
    assert caught.value.field == field
    assert caught.value.line == line
    assert str(caught.value).startswith(f"{site}:{line}: {field}: ")
    assert message in str(caught.value)


def _engine(database: NvDatabase, serial: str) -> Engine:
    engine = Engine(
        Identity(serial_number=serial), database.store(serial), T0, default_hardware(T0)
    )
    line = engine.open_line()
    for command in (
        b"write channel max number 1 write channel 1 switch output 0\r",
        b"write channel 1 sampling period 000100 write channel 1 sampling start 20000101000000\r",
    ):
        assert engine.receive(line, command, T0) and engine.receive(line, b"", T0) == []
    return engine


def test_group_commit_one_transaction_per_turn_and_writes_durable_at_once(tmp_path: Path) -> None:
    flushes: list[object] = []
    database = NvDatabase(tmp_path / "fleet.sqlite", flushes.append)
    engines = [_engine(database, f"F{n}") for n in range(5)]
    reader = sqlite3.connect(tmp_path / "fleet.sqlite")

    def rows() -> int:
        return int(reader.execute("SELECT count(*) FROM record").fetchone()[0])

    database.flush()  # rows sampled while the engines were set up
    baseline, before, scheduled = rows(), database.transactions, len(flushes)
    deadline = engines[0].next_deadline()
    assert deadline is not None
    for engine in engines:
        engine.advance(deadline)  # each samples its channel: rows wait for the end of turn
    assert rows() == baseline and len(flushes) == scheduled + 1
    database.flush()  # the end of the event-loop turn
    assert rows() == baseline + 5 and database.transactions == before + 1
    # a command line's write is on disk when its OK leaves, with the rows that waited
    engines[1].advance(deadline + 60)
    line = engines[0].open_line()
    assert engines[0].receive(line, b"write channel 1 name/abc/\r", deadline + 60)
    stored = reader.execute("SELECT logger, value FROM param WHERE key = 'channel 1 name'")
    assert stored.fetchall() == [("F0", "abc")]
    assert rows() == baseline + 7  # F1's waiting row, F0's own row sampled before the line
    database.close()


def test_served_fleet_answers_and_keeps_its_memory(tmp_path: Path) -> None:
    site = _write(
        tmp_path,
        '[[loggers]]\ncount = 3\nserial_number = "F{n:02}"\nlisten = "127.0.0.1:0"\n',
    )
    state = tmp_path / "state"

    def serve() -> tuple[subprocess.Popen[bytes], dict[str, int]]:
        proc = subprocess.Popen(
            [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(state)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        assert proc.stdout is not None
        ports: dict[str, int] = {}
        try:
            read_ports(proc, ports)
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        return proc, ports

    def read_ports(proc: subprocess.Popen[bytes], ports: dict[str, int]) -> None:
        assert proc.stdout is not None
        # (no select: the lines may arrive in one burst, already in the pipe's buffer)
        watchdog = threading.Timer(60, proc.kill)
        watchdog.start()
        try:
            while len(ports) < 3:
                words = proc.stdout.readline().decode().split()
                assert words[:1] == ["logger"], (words, proc.poll())
                ports[words[1]] = int(words[-1].rsplit(":", 1)[1])
        finally:
            watchdog.cancel()

    def ask(port: int, line: bytes) -> bytes:
        with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
            sock.sendall(line)
            answer = b""
            while not answer.endswith((b"OK\r\n", b"ERROR\r\n")):
                chunk = sock.recv(4096)
                assert chunk, answer
                answer += chunk
            return answer

    proc, ports = serve()
    try:
        assert sorted(ports) == ["F01", "F02", "F03"]
        assert ask(ports["F02"], b"read i snumber\r") == b"F02\r\nOK\r\n"
        assert ask(ports["F03"], b"write channel 1 name/north/\r") == b"OK\r\n"
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
    assert sorted(p.name for p in (state / "loggers").iterdir() if p.is_dir()) == [
        "F01",
        "F02",
        "F03",
    ]
    proc, ports = serve()
    try:
        assert ask(ports["F03"], b"read channel 1 name\r") == b"north\r\nOK\r\n"
        assert ask(ports["F01"], b"read channel 1 name\r") != b"north\r\nOK\r\n"
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=20)


def test_log_lines_name_the_logger(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    from sondalog.app.fleet import NamedDevice, install_log_names
    from sondalog.protocol.device import Event

    install_log_names()
    database = NvDatabase(tmp_path / "fleet.sqlite", lambda flush: None)
    device = NamedDevice(_engine(database, "F7"), "F7")
    with caplog.at_level(logging.WARNING):
        device.handle(Event(), T0)  # the engine logs an event it does not know
        logging.getLogger("sondalog.test").warning("outside any logger")
    messages = [record.getMessage() for record in caplog.records]
    assert messages[0].startswith("[logger F7] event "), messages
    assert messages[1] == "outside any logger"
    database.close()


class _Threads(NvDatabase):
    """Records the thread each transaction ran in."""

    threads: list[str]

    def _transaction(self, batch: list[Any]) -> None:
        self.__dict__.setdefault("threads", []).append(threading.current_thread().name)
        super()._transaction(batch)


def test_a_group_commit_is_written_by_a_thread_and_a_command_waits_for_it(tmp_path: Path) -> None:
    """Issue 24: the fleet's loop hands the rows of a turn to a writer thread (it never
    waits for their fsync); a command line's commit waits for them, then goes after them."""
    flushes: list[Callable[[], None]] = []
    database = _Threads(tmp_path / "fleet.sqlite", flushes.append, background=True)
    engines = [_engine(database, f"F{n}") for n in range(5)]
    reader = sqlite3.connect(tmp_path / "fleet.sqlite")
    for flush in flushes:
        flush()
    database.settle()
    baseline = int(reader.execute("SELECT count(*) FROM record").fetchone()[0])
    database.threads.clear()
    deadline = engines[0].next_deadline()
    assert deadline is not None
    for engine in engines:
        engine.advance(deadline)
    flushes[-1]()  # the end of the turn: handed over
    line = engines[0].open_line()
    assert engines[0].receive(line, b"write channel 1 name/abc/\r", deadline + 1)
    assert database.threads == ["sondalog-nv-writer_0", threading.current_thread().name]
    rows = reader.execute("SELECT logger, seq FROM record ORDER BY rowid").fetchall()
    assert len(rows) == baseline + 5
    stored = reader.execute("SELECT value FROM param WHERE key = 'channel 1 name'").fetchall()
    assert stored == [("abc",)]
    database.close()

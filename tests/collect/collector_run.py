"""A real ``sondalog collect`` for the collector's alarm tests (issue 21), and what its
store says about the alarms (``alarm_states`` and ``alarm_events``)."""

from __future__ import annotations

import contextlib
import signal
import sqlite3
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

from served_logger import CLI


@contextlib.contextmanager
def collecting(config: Path) -> Iterator[subprocess.Popen[bytes]]:
    """``sondalog collect CONFIG`` until the block ends (then SIGTERM: a clean stop)."""
    log = (config.parent / "collect.log").open("ab")
    proc = subprocess.Popen([*CLI, "collect", str(config)], stdout=log, stderr=log)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()


def collect_log(config: Path) -> str:
    path = config.parent / "collect.log"
    return path.read_text(errors="replace") if path.exists() else ""


def states(store: Path) -> dict[tuple[str, str], str]:
    """(rule, subject) -> state, of every alarm the store knows."""
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(store, timeout=5)) as db,
    ):
        rows = db.execute("SELECT rule, subject, state FROM alarm_states").fetchall()
        return {(str(r), str(s)): str(st) for r, s, st in rows}
    return {}


def events(store: Path, rule: str) -> list[tuple[str, str, float | None]]:
    """(what, subject, value) of ``rule``'s history, oldest first."""
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(store, timeout=5)) as db,
    ):
        rows = db.execute(
            "SELECT what, subject, value FROM alarm_events WHERE rule = ? ORDER BY id", (rule,)
        ).fetchall()
        return [(str(w), str(s), v) for w, s, v in rows]
    return []


def wait_for(condition: Callable[[], bool], timeout: float, config: Path, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}; log:\n{collect_log(config)}")
        time.sleep(0.1)


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=60)

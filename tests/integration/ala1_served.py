"""Fixtures for integration tests: real ``sondalog logger serve`` subprocesses over real TCP."""

from __future__ import annotations

import contextlib
import os
import select
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

STARTUP_TIMEOUT = 15.0
SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]


class ServedLogger:
    """A ``sondalog logger serve`` subprocess bound to a free loopback port."""

    def __init__(self, state: Path, *extra: str) -> None:
        self.state = state
        self.log_path = state.parent / f"{state.name}.stderr.log"
        self._log = self.log_path.open("ab")
        self.proc = subprocess.Popen(
            [*SERVE, "--listen", "127.0.0.1:0", "--state", str(state), *extra],
            stdout=subprocess.PIPE,
            stderr=self._log,
        )
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], STARTUP_TIMEOUT)
        line = self.proc.stdout.readline().decode() if ready else ""
        if not line.startswith("listening on "):
            self.kill()
            raise RuntimeError(f"server did not start: {line!r} {self.stderr()}")
        self.host, _, port = line.removeprefix("listening on ").strip().rpartition(":")
        self.port = int(port)
        self.url = f"tcp://{self.host}:{self.port}"

    def stderr(self) -> str:
        return self.log_path.read_text(errors="replace")

    def connect(self, timeout: float = 5.0) -> socket.socket:
        sock = socket.create_connection((self.host, self.port), timeout=timeout)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return sock

    def alive(self) -> bool:
        return self.proc.poll() is None

    def signal(self, signum: int) -> int:
        self.proc.send_signal(signum)
        return self.proc.wait(timeout=10)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=10)
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._log.close()


def exchange(sock: socket.socket, data: bytes, expect_end: bytes, timeout: float = 5.0) -> bytes:
    """Send ``data`` and read until the received bytes end with ``expect_end``."""
    sock.sendall(data)
    return read_until(sock, expect_end, timeout)


def read_until(sock: socket.socket, expect_end: bytes, timeout: float = 5.0) -> bytes:
    deadline = time.monotonic() + timeout
    buf = b""
    while not buf.endswith(expect_end):
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise AssertionError(f"timed out waiting for {expect_end!r}; got {buf!r}")
        sock.settimeout(remaining)
        try:
            chunk = sock.recv(65536)
        except TimeoutError:
            continue
        if not chunk:
            raise AssertionError(f"connection closed; got {buf!r}")
        buf += chunk
    return buf


def read_quiet(sock: socket.socket, period: float = 0.15) -> bytes:
    """Whatever arrives until the socket has been silent for ``period`` seconds."""
    buf = b""
    sock.settimeout(period)
    while True:
        try:
            chunk = sock.recv(65536)
        except (TimeoutError, ConnectionResetError):
            return buf
        if not chunk:
            return buf
        buf += chunk


@pytest.fixture
def serve(tmp_path: Path) -> Iterator[Callable[..., ServedLogger]]:
    """Start servers with ``serve(*extra_args, state=None)``; all are killed at the end."""
    started: list[ServedLogger] = []

    def start(*extra: str, state: Path | None = None) -> ServedLogger:
        served = ServedLogger(state or tmp_path / "state", *extra)
        started.append(served)
        return served

    yield start
    for served in started:
        if served.alive():
            served.proc.send_signal(signal.SIGTERM)
            with contextlib.suppress(subprocess.TimeoutExpired):
                served.proc.wait(timeout=5)
        served.kill()


@pytest.fixture(scope="module")
def shared_logger(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ServedLogger]:
    """One server for a whole test module (tests must not depend on each other's writes)."""
    served = ServedLogger(tmp_path_factory.mktemp("shared") / "state")
    yield served
    if served.alive():
        os.kill(served.proc.pid, signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            served.proc.wait(timeout=5)
    served.kill()

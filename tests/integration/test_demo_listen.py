"""``make demo`` (``python -m sondalog.demo``) when port 10001 is taken, and ``--listen``
(issue 16, item 6); SIGTERM stops it as Ctrl-C does."""

from __future__ import annotations

import contextlib
import errno
import re
import signal
import socket
import subprocess
from collections.abc import Iterator
from pathlib import Path

from demo_process import DEMO, DemoProcess


@contextlib.contextmanager
def demo(cwd: Path, *args: str, stop: int = signal.SIGINT) -> Iterator[tuple[DemoProcess, int]]:
    """The demo, yielded with its first logger's port once it serves; stopped with ``stop``
    (which must end it with exit status 0)."""
    with DemoProcess(cwd, *args) as running:
        text = running.wait_for("Serving until Ctrl-C.")
        match = re.search(r"sondalog term tcp://127\.0\.0\.1:(\d+)", text)
        assert match, text
        yield running, int(match.group(1))
        running.proc.send_signal(stop)
        assert running.proc.wait(timeout=20) == 0


def _listener(port: int = 0) -> socket.socket:
    sock = socket.socket()
    sock.bind(("127.0.0.1", port))
    sock.listen()
    return sock


def test_listen_chooses_the_address(tmp_path: Path) -> None:
    with _listener() as probe:
        port = probe.getsockname()[1]
    with demo(tmp_path, "--listen", f"127.0.0.1:{port}", stop=signal.SIGTERM) as (_, got):
        assert got == port
        with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
            sock.sendall(b"read i version\r")
            assert sock.recv(100).startswith(b"2.10\r\n")


def test_a_taken_listen_port_stops_with_a_message(tmp_path: Path) -> None:
    with _listener() as taken:
        port = taken.getsockname()[1]
        done = subprocess.run(
            [*DEMO, "--listen", f"127.0.0.1:{port}"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert done.returncode == 1
    assert f"cannot serve the demo on 127.0.0.1:{port}: " in done.stderr
    bad = subprocess.run([*DEMO, "--listen", "10001"], capture_output=True, text=True, timeout=30)
    assert bad.returncode == 2 and "--listen: expected HOST:PORT" in bad.stderr


def test_a_taken_10001_gives_a_free_port_and_says_which(tmp_path: Path) -> None:
    with contextlib.ExitStack() as stack:
        try:
            stack.enter_context(_listener(10001))
        except OSError as exc:  # taken already (a demo runs on this machine): just as good
            if exc.errno != errno.EADDRINUSE:
                raise
        with demo(tmp_path) as (running, port):
            assert port != 10001
            (line,) = [x for x in running.lines if x.startswith("port 10001 is taken (")]
            assert f"logger CABLE-01 uses the free port {port} instead" in line
            assert 'make demo ARGS="--listen 127.0.0.1:PORT"' in line

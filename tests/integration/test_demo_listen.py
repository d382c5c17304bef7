"""``make demo`` (``python -m sondalog.demo``) when port 10001 is taken, and ``--listen``
(issue 16, item 6)."""

from __future__ import annotations

import contextlib
import errno
import select
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

DEMO = [sys.executable, "-m", "sondalog.demo"]


@contextlib.contextmanager
def demo(cwd: Path, *args: str) -> Iterator[tuple[subprocess.Popen[str], list[str]]]:
    """The demo with stdout and stderr merged; yields it once it listens, stops it after."""
    proc = subprocess.Popen(
        [*DEMO, *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    assert proc.stdout is not None
    lines: list[str] = []
    try:
        while not lines or not lines[-1].startswith("listening on "):
            ready, _, _ = select.select([proc.stdout], [], [], 20)
            line = proc.stdout.readline() if ready else ""
            assert line, "".join(lines)
            lines.append(line)
        yield proc, lines
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        proc.stdout.close()


def _listener(port: int = 0) -> socket.socket:
    sock = socket.socket()
    sock.bind(("127.0.0.1", port))
    sock.listen()
    return sock


def test_listen_chooses_the_address(tmp_path: Path) -> None:
    with _listener() as probe:
        port = probe.getsockname()[1]
    with demo(tmp_path, "--listen", f"127.0.0.1:{port}") as (_, lines):
        assert lines[-1] == f"listening on 127.0.0.1:{port}\n"
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
        with demo(tmp_path) as (_, lines):
            port = int(lines[-1].rsplit(":", 1)[1])
            assert port != 10001
            assert lines[0].startswith("port 10001 is taken (")
            assert f"using the free port {port} instead" in lines[0]
            assert 'make demo ARGS="--listen 127.0.0.1:PORT"' in lines[0]

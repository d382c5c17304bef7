"""Issue 16 item 4: with ``--speed``, the module's work runs fast but the line keeps real time.

What happens on a line (the entry timeout, XMODEM, ``pause``) follows real time; sampling and
the module clock follow ``--speed`` (docs/decisions.md "Time base")."""

from __future__ import annotations

import shutil
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from ala1_served import ServedLogger

Serve = Callable[..., ServedLogger]


def _answer(sock: object, end: bytes = b"OK\r\n", limit: float = 10.0) -> bytes:
    import socket

    assert isinstance(sock, socket.socket)
    data = b""
    stop = time.monotonic() + limit
    while not data.endswith(end) and time.monotonic() < stop:
        data += sock.recv(4096)
    return data


def test_a_slowly_typed_command_survives_a_fast_clock(serve: Serve) -> None:
    served = serve("--speed", "3600")
    with served.connect() as sock:
        sock.sendall(b"read i ver")
        time.sleep(0.5)  # half a real second: 30 minutes of module time
        sock.sendall(b"sion\r")
        assert _answer(sock) == b"2.10\r\nOK\r\n"


def test_the_module_clock_still_runs_fast(serve: Serve) -> None:
    served = serve("--speed", "3600")
    with served.connect() as sock:
        sock.sendall(b"write date 20260101000000\r")
        assert _answer(sock) == b"OK\r\n"
        time.sleep(1.0)
        sock.sendall(b"read date\r")
        stamp = _answer(sock).split(b"\r\n")[0].decode()
    assert stamp >= "20260101005500", stamp  # about an hour later


def test_pause_waits_in_real_time(serve: Serve) -> None:
    served = serve("--speed", "3600")
    with served.connect() as sock:
        start = time.monotonic()
        sock.sendall(b"pause 1 read i version\r")
        assert _answer(sock).endswith(b"2.10\r\nOK\r\n")
        assert time.monotonic() - start >= 0.9  # a real second, not 1/3600 of one


@pytest.mark.skipif(shutil.which("rx") is None, reason="lrzsz (rx) is not installed")
def test_xmodem_waits_for_a_real_peer(serve: Serve, tmp_path: Path) -> None:
    served = serve("--speed", "3600")
    with served.connect() as sock:
        sock.setblocking(True)
        sock.sendall(b"write text /row/\r")
        assert _answer(sock) == b"OK\r\n"
        sock.sendall(b"read special file record xmodem\r")
        time.sleep(1.5)  # a peer that takes a moment to start: 90 minutes of module time
        done = subprocess.run(
            ["rx", "-c", "record"], stdin=sock, stdout=sock, stderr=subprocess.PIPE,
            timeout=60, cwd=tmp_path,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
    assert b",3,/row/\r\n" in (tmp_path / "record").read_bytes()

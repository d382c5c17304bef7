"""Drive a pure XMODEM end over real file descriptors, with time.monotonic() as its clock."""

from __future__ import annotations

import os
import select
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

from xmodem_line import End

import xmodem  # type: ignore[import-untyped]


def write_all(fd: int, data: bytes) -> None:
    while data:
        data = data[os.write(fd, data) :]


def pump(
    end: End,
    read_fd: int,
    write_fd: int,
    *,
    limit: float = 20.0,
    writes: list[bytes] | None = None,
) -> float:
    """Run ``end`` until it is done (or the peer closes); returns the seconds it took.

    ``writes`` collects every non-empty output of ``end`` (one block per write for a sender).
    """
    log = writes if writes is not None else []

    def put(data: bytes) -> None:
        if data:
            log.append(data)
            write_all(write_fd, data)

    t0 = now = time.monotonic()
    put(end.start(now))
    while not end.done:
        if now - t0 > limit:
            raise TimeoutError(f"transfer not finished after {limit} s")
        deadline = end.next_deadline()
        wait = 0.05 if deadline is None else min(max(deadline - now, 0.0), 0.05)
        ready, _, _ = select.select([read_fd], [], [], wait)
        now = time.monotonic()
        if ready:
            data = os.read(read_fd, 65536)
            if not data:
                break
            put(end.receive(data, now))
        put(end.advance(now))
    return time.monotonic() - t0


class PackagePeer:
    """The ``xmodem`` package (blocking) in a thread, on one end of a socketpair."""

    def __init__(self, mode: str = "xmodem") -> None:
        self.ours, self.theirs = socket.socketpair()
        self.modem = xmodem.XMODEM(self._getc, self._putc, mode=mode)
        self.result: Any = None
        self._thread: threading.Thread | None = None

    def _getc(self, size: int, timeout: float = 1) -> bytes | None:
        end = time.monotonic() + timeout
        got = b""
        while len(got) < size:
            left = end - time.monotonic()
            if left <= 0:
                break
            self.theirs.settimeout(left)
            try:
                chunk = self.theirs.recv(size - len(got))
            except TimeoutError:
                break
            if not chunk:
                break
            got += chunk
        return got or None

    def _putc(self, data: bytes, timeout: float = 1) -> int:
        self.theirs.sendall(data)
        return len(data)

    def run(self, work: Callable[[xmodem.XMODEM], Any]) -> None:
        def target() -> None:
            self.result = work(self.modem)

        self._thread = threading.Thread(target=target, daemon=True)
        self._thread.start()

    def join(self, timeout: float = 20.0) -> Any:
        assert self._thread is not None
        self._thread.join(timeout)
        assert not self._thread.is_alive(), "xmodem package peer still running"
        return self.result

    def close(self) -> None:
        self.ours.close()
        self.theirs.close()

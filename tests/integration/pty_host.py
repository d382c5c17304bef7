"""The host end of a serial line in tests: a tty (a served logger's pty symlink, one end of a
``socat`` pty pair) opened raw, 8N1, at a chosen speed, with timed reads."""

from __future__ import annotations

import os
import select
import termios
import time
import tty
from pathlib import Path


def text_lines(count: int, width: int = 100) -> bytes:
    """``count`` pipelined ``read text/.../`` commands; each answers ``width + 6`` bytes."""
    return b"".join(b"read text/" + bytes([65 + i % 26]) * width + b"/\r" for i in range(count))


def answer_size(count: int, width: int = 100) -> int:
    return count * (width + 2 + 4)  # the text, CR LF, OK CR LF


class HostPort:
    """A tty in raw mode at ``baud`` (8N1, no flow control in the driver)."""

    def __init__(self, path: Path | str, baud: int = 9600) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        self.set_speed(baud)

    def set_speed(self, baud: int) -> None:
        attrs = termios.tcgetattr(self.fd)
        rate = getattr(termios, f"B{baud}")
        attrs[2] &= ~(termios.IXON | termios.IXOFF)  # iflag: XON/XOFF are the module's
        attrs[4] = attrs[5] = rate
        termios.tcsetattr(self.fd, termios.TCSANOW, attrs)

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.fd, view) :]

    def read_timed(
        self, until: bytes | int, timeout: float
    ) -> tuple[bytes, list[tuple[float, int]]]:
        """Read until the data ends with ``until`` (bytes) or holds ``until`` bytes (int).

        Returns the data and the (monotonic time, size) of every read.
        """
        deadline = time.monotonic() + timeout
        buf = bytearray()
        reads: list[tuple[float, int]] = []
        while not (buf.endswith(until) if isinstance(until, bytes) else len(buf) >= until):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"timed out waiting for {until!r}; got {bytes(buf[-200:])!r}")
            ready, _, _ = select.select([self.fd], [], [], remaining)
            if ready:
                chunk = os.read(self.fd, 65536)
                reads.append((time.monotonic(), len(chunk)))
                buf += chunk
        return bytes(buf), reads

    def read_until(self, until: bytes | int, timeout: float = 5.0) -> bytes:
        return self.read_timed(until, timeout)[0]

    def read_quiet(self, period: float) -> bytes:
        """Whatever arrives until the line has been silent for ``period`` seconds."""
        buf = b""
        while select.select([self.fd], [], [], period)[0]:
            buf += os.read(self.fd, 65536)
        return buf

    def ask(self, command: bytes, timeout: float = 5.0) -> bytes:
        """Send one command line; its answer up to the final ``OK``."""
        self.write(command + b"\r")
        return self.read_until(b"OK\r\n", timeout)

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def __enter__(self) -> HostPort:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def paced_seconds(reads: list[tuple[float, int]], baud: float) -> tuple[float, float]:
    """(measured, theoretical) time from the first read to the last byte.

    The bytes of the first read had already left when it returned, so the theory counts the
    rest: 10 bit times a byte (8N1).
    """
    first_time, first_size = reads[0]
    total = sum(size for _, size in reads)
    return reads[-1][0] - first_time, (total - first_size) * 10 / baud

"""Bad input is normal input (DESIGN.md point 6): over TCP, malformed lines get the error
response (§3.3.1) and garbage never stops the server."""

from __future__ import annotations

import contextlib
import random
import socket

import pytest
from ala1_served import ServedLogger, exchange, read_quiet

ALIVE = (b"read i version\r", b"2.10\r\nOK\r\n")


def error_response(line: bytes) -> bytes:
    return line + b"\r\nERROR\r\n"


@pytest.mark.parametrize(
    "line",
    [
        b"read",  # half commands
        b"write",
        b"read channel",
        b"read channel 1",  # a subtree, not a leaf
        b"write date",
        b"write channel 1 name",
        b"check",
        b"sum",
        b"reed date",  # unknown keywords
        b"read dates",
        b"read i versio",
        b"frobnicate 12",
        b"write channel max number 13",  # out of range (2.10 has 12 channels)
        b"write channel max number 0",
        b"write com speed 1234",
        b"write date 20070230000000",  # impossible calendar date
        b"write date 123",  # bad digit count
        b"pause 3600 read date",  # pause must be < 3600 (§8.5.1)
        b"read channel 13 name",
        b"write i version 3.00",  # read-only
        b"read date read",  # chained half command: nothing runs (atomicity)
    ],
)
def test_malformed_lines_get_the_error_response(shared_logger: ServedLogger, line: bytes) -> None:
    with shared_logger.connect() as sock:
        assert exchange(sock, line + b"\r", b"ERROR\r\n") == error_response(line)
        assert exchange(sock, *ALIVE) == ALIVE[1]


def test_overlong_line_answers_with_its_first_120_characters(shared_logger: ServedLogger) -> None:
    with shared_logger.connect() as sock:
        line = b"read date " + b"x" * 300
        assert exchange(sock, line + b"\r", b"ERROR\r\n") == error_response(line[:120])
        # Even a valid command longer than 120 characters is an error (§3.4.1).
        long_valid = b"read date" + b" " * 200
        got = exchange(sock, long_valid + b"\r", b"ERROR\r\n")
        assert got == error_response(long_valid[:120])
        assert exchange(sock, *ALIVE) == ALIVE[1]


def test_quiet_suppresses_the_error_and_wrong_check_is_silent(shared_logger: ServedLogger) -> None:
    with shared_logger.connect() as sock:
        sock.sendall(b"quiet reed date\rcheck 1 read date\r")
        assert read_quiet(sock, 0.15) == b""
        assert exchange(sock, *ALIVE) == ALIVE[1]


def _garbage(rng: random.Random) -> bytes:
    kind = rng.randrange(4)
    if kind == 0:  # random bytes, any value
        return rng.randbytes(rng.randrange(1, 400))
    if kind == 1:  # printable noise with line ends
        alphabet = b"abcdefghijklmnopqrstuvwxyz0123456789 /+-.,*&\r\n"
        return bytes(rng.choice(alphabet) for _ in range(rng.randrange(1, 300)))
    if kind == 2:  # keywords in random order
        words = [
            b"read",
            b"write",
            b"channel",
            b"1",
            b"name",
            b"date",
            b"sum",
            b"crcsum",
            b"quiet",
            b"number",
            b"counter",
            b"check",
            b"i",
            b"version",
            b"/x/",
            b"12",
        ]
        return b" ".join(rng.choice(words) for _ in range(rng.randrange(1, 12))) + b"\r"
    return b"\x1b+" + rng.randbytes(rng.randrange(1, 50)) + b"\x08\x7f\x1b"  # line editing


def test_random_garbage_from_many_connections_never_stops_the_server(
    shared_logger: ServedLogger,
) -> None:
    rng = random.Random(20070618)
    for _ in range(30):
        socks = [shared_logger.connect() for _ in range(4)]
        for _ in range(10):
            sock = rng.choice(socks)
            with contextlib.suppress(OSError):
                sock.sendall(_garbage(rng))
        for sock in socks:
            if rng.random() < 0.5:
                sock.close()  # abruptly, possibly mid-line
                continue
            read_quiet(sock, 0.01)
            sock.sendall(b"\x1b")  # ESC drops any partial command before the close
            sock.close()
    assert shared_logger.alive()
    with shared_logger.connect() as sock:
        assert exchange(sock, *ALIVE) == ALIVE[1]
    assert "Traceback" not in shared_logger.stderr()


def test_binary_zero_and_high_bytes_are_answered(shared_logger: ServedLogger) -> None:
    with shared_logger.connect() as sock:
        for line in (b"\x00", b"read \xff\xfe date", b"read date\x00"):
            got = exchange(sock, line + b"\r", b"ERROR\r\n")
            assert got == error_response(line)
        assert exchange(sock, *ALIVE) == ALIVE[1]


def test_a_client_that_never_reads_does_not_block_others(shared_logger: ServedLogger) -> None:
    hog = shared_logger.connect()
    hog.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    try:
        hog.setblocking(False)
        payload = b"read channel name read channel name read channel name\r" * 2000
        with contextlib.suppress(BlockingIOError):
            hog.send(payload)
        with shared_logger.connect() as sock:
            assert exchange(sock, *ALIVE) == ALIVE[1]
    finally:
        hog.close()

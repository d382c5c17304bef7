"""SIGKILL in the middle of a stream of writes, then a restart over the same state directory:
every write that got its ``OK`` is there, and no line is ever half applied (DESIGN.md point 5,
issue 2 "Non-volatile memory")."""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable

from ala1_served import ServedLogger, exchange

Serve = Callable[..., ServedLogger]

WRITES = 5000
#: Three parameters written by one chained line (§7.1): all or none must be applied.
LINE = "write channel 1 name/n{0}/ write channel 2 name/m{0}/ write i description/d{0}/\r"
READ_BACK = b"read channel 1 name read channel 2 name read i description\r"


def _stream_writes_and_kill(served: ServedLogger, start: int, kill_after: int) -> int:
    """Pipeline many chained writes; SIGKILL after ``kill_after`` OKs; the last acked index."""
    lines = [LINE.format(i).encode() for i in range(start, start + WRITES)]
    acked = start - 1
    with served.connect() as sock:

        def send() -> None:  # keeps writing while the main thread reads the answers
            try:
                for n in range(0, WRITES, 50):
                    sock.sendall(b"".join(lines[n : n + 50]))
            except OSError:
                pass  # the server is gone

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        buf = b""
        deadline = time.monotonic() + 20
        while acked < start + kill_after - 1:
            assert time.monotonic() < deadline, f"no progress: {buf[-200:]!r}"
            chunk = sock.recv(65536)
            assert chunk, "server closed early"
            buf += chunk
            acked = start - 1 + buf.count(b"OK\r\n")
        served.proc.kill()  # SIGKILL while the rest of the stream is in flight
        served.proc.wait(timeout=10)
        try:
            sock.settimeout(1)
            while chunk := sock.recv(65536):
                buf += chunk
        except OSError:
            pass
        sender.join(timeout=10)
        assert b"ERROR" not in buf
        return start - 1 + buf.count(b"OK\r\n")


def test_sigkill_mid_stream_loses_nothing_acknowledged(serve: Serve) -> None:
    served = serve()
    start = 0
    for round_, kill_after in enumerate((37, 111, 5)):
        acked = _stream_writes_and_kill(served, start, kill_after)
        assert acked >= start + kill_after - 1
        served.kill()
        served = serve()  # same state directory
        with served.connect() as sock:
            got = exchange(sock, READ_BACK, b"OK\r\n").decode()
        match = re.fullmatch(r"n(\d+)\r\nm(\d+)\r\nd(\d+)\r\nOK\r\n", got)
        assert match, got
        first, second, third = (int(g) for g in match.groups())
        assert first == second == third, f"half-applied line in round {round_}: {got!r}"
        assert acked <= first < start + WRITES, (acked, first)
        assert first < start + WRITES - 1, "the kill came after the last write"
        start += WRITES

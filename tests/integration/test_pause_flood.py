"""Issue 20: a client that floods its line while its command waits in ``pause`` (§8.5.1), or
that never reads its answers, does not grow the logger's memory: the logger holds a bounded
backlog and stops reading that connection (the client's sends block), while other clients are
served as before."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path

from ala1_served import ServedLogger, exchange

Serve = Callable[..., ServedLogger]

COMMAND = b"read i version\r"
CHUNK = COMMAND * 4400  # 66 KB
UNKNOWN = b"x" * 119 + b"\r"  # answered with itself and ERROR: more out than in
FLOOD = 40 * 1024 * 1024
STALLED = 1.0  # seconds without progress: the server no longer reads the flooder


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


class Flooder(threading.Thread):
    """Sends up to ``total`` bytes of command lines, as fast as the server takes them."""

    def __init__(self, sock: socket.socket, total: int = FLOOD, chunk: bytes = CHUNK) -> None:
        super().__init__(daemon=True)
        self.sock = sock
        self.total = total
        self.chunk = chunk
        self.sent = 0
        self.stop = threading.Event()

    def run(self) -> None:
        self.sock.settimeout(0.05)
        while self.sent < self.total and not self.stop.is_set():
            try:
                self.sent += self.sock.send(self.chunk)
            except TimeoutError:
                continue
            except OSError:
                return

    def wait_done_or_stalled(self) -> None:
        seen, since = -1, time.monotonic()
        while self.is_alive() and time.monotonic() - since < STALLED:
            if self.sent != seen:
                seen, since = self.sent, time.monotonic()
            time.sleep(0.05)


def test_a_flood_during_pause_leaves_memory_bounded_and_others_served(serve: Serve) -> None:
    served = serve("--protocol", "2.10")
    flooder = served.connect(timeout=30)
    prober = served.connect(timeout=30)
    assert exchange(prober, COMMAND, b"OK\r\n") == b"2.10\r\nOK\r\n"
    before = rss_kib(served.proc.pid)
    flooder.sendall(b"pause 3599 read i version\r")
    flood = Flooder(flooder)
    flood.start()
    try:
        flood.wait_done_or_stalled()
        # another client is served meanwhile
        assert exchange(prober, COMMAND, b"OK\r\n", timeout=15) == b"2.10\r\nOK\r\n"
        grown = rss_kib(served.proc.pid) - before
        assert grown < 50 * 1024, f"RSS grew by {grown} KiB after {flood.sent} bytes"
        assert flood.sent < FLOOD, "the server kept reading a line whose command waits"
    finally:
        flood.stop.set()
        flood.join(timeout=10)
        flooder.close()
    assert exchange(prober, COMMAND, b"OK\r\n", timeout=15) == b"2.10\r\nOK\r\n"
    assert served.alive()


def test_what_waits_behind_a_pause_is_all_answered(serve: Serve) -> None:
    """Backpressure, not loss: every command sent during the pause is answered after it."""
    served = serve("--protocol", "2.10")
    count = 12000  # 180 KB: more than the logger holds and than the runtime queues
    with served.connect(timeout=60) as client:
        sender = threading.Thread(
            target=client.sendall, args=(b"pause 1 read i version\r" + COMMAND * count,)
        )
        sender.start()
        answers = b""
        while answers.count(b"OK\r\n") < count + 1:
            chunk = client.recv(65536)
            assert chunk, answers[-200:]
            answers += chunk
        sender.join(timeout=30)
    assert answers == b"2.10\r\nOK\r\n" * (count + 1)


def test_a_client_that_never_reads_its_answers_is_throttled(serve: Serve) -> None:
    """Its answers pile up (kernel buffers, then the transport's): reading it stops until it
    reads, even while the runtime's own queue of its input has room (tcp.py keeps both
    reasons to stop reading; one alone does not resume what the other stopped)."""
    served = serve("--protocol", "2.10")
    client = socket.socket()
    client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)  # fills sooner
    client.settimeout(30)
    client.connect((served.host, served.port))
    assert exchange(client, COMMAND, b"OK\r\n") == b"2.10\r\nOK\r\n"
    before = rss_kib(served.proc.pid)
    flood = Flooder(client, total=FLOOD // 2, chunk=UNKNOWN * 550)
    flood.start()
    try:
        flood.wait_done_or_stalled()
        grown = rss_kib(served.proc.pid) - before
        # bounded by the kernel's socket buffers and the transport's high-water mark
        assert grown < 50 * 1024, f"RSS grew by {grown} KiB after {flood.sent} bytes"
        assert flood.sent < flood.total, "the server kept reading a client that reads nothing"
    finally:
        flood.stop.set()
        flood.join(timeout=10)
        client.close()
    with served.connect(timeout=30) as other:
        assert exchange(other, COMMAND, b"OK\r\n", timeout=15) == b"2.10\r\nOK\r\n"

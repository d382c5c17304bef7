"""Issue 9: fair service. A client flooding long lines cannot hold up another's command: each
line gets one command line per turn of the event loop, round-robin."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable

from ala1_served import ServedLogger

Serve = Callable[..., ServedLogger]

FLOOD_LINE = b"read channel name read channel name read channel name read channel name\r"
FLOOD_LINES = 20000


def _drain(sock: socket.socket, expected_oks: int, received: list[int]) -> None:
    seen = 0
    buffer = b""
    while seen < expected_oks:
        chunk = sock.recv(65536)
        if not chunk:
            return
        buffer += chunk
        seen += buffer.count(b"OK\r\n")
        buffer = buffer[buffer.rfind(b"\n") + 1 :]
        received[0] = seen


def test_a_flood_does_not_hold_up_another_line(serve: Serve) -> None:
    served = serve("--protocol", "2.10")
    with served.connect(timeout=30) as setup:
        setup.sendall(b"write channel max number 12\r")
        assert setup.recv(100) == b"OK\r\n"
    flooder = served.connect(timeout=60)
    prober = served.connect(timeout=30)
    received = [0]
    reader = threading.Thread(target=_drain, args=(flooder, FLOOD_LINES, received))
    reader.start()
    # thousands of lines queued at once (sent from a thread: the server reads them as it goes)
    flood = threading.Thread(target=flooder.sendall, args=(FLOOD_LINE * FLOOD_LINES,))
    flood.start()
    try:
        while received[0] < 100:  # the flood is being served
            time.sleep(0.001)
        before = received[0]
        prober.sendall(b"read i version\r")
        answer = b""
        while not answer.endswith(b"OK\r\n"):
            answer += prober.recv(100)
        done_when_probed = received[0]
        assert answer == b"2.10\r\nOK\r\n"
        # the prober was served long before the flood was: round-robin, not first-come
        assert done_when_probed - before < 500, (before, done_when_probed)
        assert done_when_probed < FLOOD_LINES // 2
    finally:
        flood.join(timeout=120)
        reader.join(timeout=120)
        flooder.close()
        prober.close()
    assert received[0] == FLOOD_LINES  # and the flooder lost nothing


def test_listening_beyond_loopback_needs_an_explicit_option() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "sondalog", "logger", "serve", "--listen", "0.0.0.0:0"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2
    assert "--allow-remote" in done.stderr and "no authentication" in done.stderr

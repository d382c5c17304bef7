"""Fair service under a flood (issue 9): one client floods long lines, another probes.

Not a test: prints the prober's latency (median, p95, max) for ``read i version`` while a
flooder keeps the logger busy with 120-character lines, against a real
``sondalog logger serve`` subprocess on loopback. Goal: a few milliseconds of engine time.
Run: ``.venv/bin/python benchmarks/bench_fairness.py [--probes N]``.
"""

from __future__ import annotations

import argparse
import contextlib
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

SERVE = [sys.executable, "-m", "sondalog", "logger", "serve", "--listen", "127.0.0.1:0"]
FLOOD = b"read channel name read channel name read channel name read channel name read i name\r"


def _flood(port: int, stop: threading.Event, count: list[int]) -> None:
    sock = socket.create_connection(("127.0.0.1", port))
    sock.setblocking(False)
    batch = FLOOD * 200
    while not stop.is_set():
        with contextlib.suppress(BlockingIOError):
            sock.send(batch)
        try:
            while True:
                data = sock.recv(1 << 16)
                if not data:
                    return
                count[0] += data.count(b"OK\r\n")
        except BlockingIOError:
            time.sleep(0.001)
    sock.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--probes", type=int, default=200)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.Popen([*SERVE, "--state", tmp], stdout=subprocess.PIPE)
        assert proc.stdout is not None
        port = int(proc.stdout.readline().decode().rsplit(":", 1)[1])
        try:
            with socket.create_connection(("127.0.0.1", port)) as setup:
                setup.sendall(b"write channel max number 12\r")
                setup.recv(100)
            stop = threading.Event()
            count = [0]
            flooder = threading.Thread(target=_flood, args=(port, stop, count), daemon=True)
            flooder.start()
            time.sleep(1.0)  # let the flood build up
            latencies = []
            with socket.create_connection(("127.0.0.1", port)) as probe:
                probe.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                for _ in range(args.probes):
                    start = time.perf_counter()
                    probe.sendall(b"read i version\r")
                    answer = b""
                    while not answer.endswith(b"OK\r\n"):
                        answer += probe.recv(100)
                    latencies.append((time.perf_counter() - start) * 1000)
                    time.sleep(0.01)
            stop.set()
            flooder.join(5)
        finally:
            proc.terminate()
            proc.wait(10)
    latencies.sort()
    print(f"flood lines answered during the run: {count[0]}")
    median = statistics.median(latencies)
    p95 = latencies[int(len(latencies) * 0.95) - 1]
    print(
        f"prober latency over {len(latencies)} probes: median {median:.2f} ms,"
        f" p95 {p95:.2f} ms, max {latencies[-1]:.2f} ms"
    )


if __name__ == "__main__":
    main()

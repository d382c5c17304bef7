"""The HCTMPS1 bus on an RS-485 link: ``PV`` requests per second through a pty pair.

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_rs485.py`` (needs socat).

``sondalog bus serve --serial A --rs485 auto`` on one end of a socat pty pair; the bus master
on the other end, once through ``serial://B?rs485=auto`` (writes in the port's thread, the
inter-frame gap before each request) and once through the plain ``serial://B`` stream link.
A pty has no line time, so the figures show the software's cost per transaction and what the
inter-frame gap adds; on a real 9600-baud line each ~25-byte request and answer also take
their ~26 ms of line time.
"""

from __future__ import annotations

import asyncio
import os
import select
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sondalog.client.bus import BusMaster
from sondalog.client.bus_links import inter_frame_gap

REQUESTS = 200


def _wait_line(proc: subprocess.Popen[bytes]) -> str:
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout.fileno()], [], [], 20)
    if not ready:
        raise RuntimeError("bus serve printed nothing")
    return os.read(proc.stdout.fileno(), 4096).decode()


async def _run(url: str) -> float:
    master = await BusMaster.open(url)
    try:
        await master.pv("T1")
        start = time.perf_counter()
        for _ in range(REQUESTS):
            await master.pv("T1")
        return time.perf_counter() - start
    finally:
        await master.close()


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        a, b = Path(tmp) / "a", Path(tmp) / "b"
        socat = subprocess.Popen(
            ["socat", f"pty,raw,echo=0,link={a}", f"pty,raw,echo=0,link={b}"],
            stderr=subprocess.DEVNULL,
        )
        while not (a.exists() and b.exists()):
            time.sleep(0.02)
        serve = subprocess.Popen(
            [sys.executable, "-m", "sondalog", "bus", "serve", "--listen", "127.0.0.1:0",
             "--state", f"{tmp}/state", "--serial", str(a), "--rs485", "auto"],
            stdout=subprocess.PIPE,
        )  # fmt: skip
        try:
            _wait_line(serve)
            print(f"{REQUESTS} PV requests to T1 over a pty pair (bus serve --rs485 auto)")
            print(f"inter-frame gap at 9600 baud: {inter_frame_gap(9600) * 1000:.2f} ms")
            for name, url in (
                ("rs485=auto link", f"serial://{b}?baud=9600&rs485=auto"),
                ("plain serial link", f"serial://{b}?baud=9600"),
            ):
                elapsed = asyncio.run(_run(url))
                per = elapsed / REQUESTS * 1000
                print(f"{name:18} {REQUESTS / elapsed:7.1f} req/s  {per:6.2f} ms per request")
        finally:
            serve.send_signal(signal.SIGTERM)
            serve.wait(10)
            socat.terminate()
            socat.wait(5)


if __name__ == "__main__":
    main()

"""Benchmark: what reading a logger's configuration adds to a collector's contact (issue 22).

Serves one logger of each protocol version (``sondalog logger serve``, TCP on loopback, two
channels sampled) and makes ``--contacts`` contacts with the collector's own
:class:`~sondalog.collect.sources.LoggerSource` (download, channel types, record status), with
the configuration check off (``config_every = 0``) and on (every contact: read whole, hashed,
compared with the stored one), interleaved. Prints the wall time per contact, best and median,
the difference, the collector's CPU time per contact, and the bytes of the configuration's
reads and answers (what they cost on a slow line: at 9600 baud at least the bytes sent x 10
bits / 9600).

Run: ``.venv/bin/python benchmarks/bench_config_watch.py [--contacts 30]``.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import select
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sondalog.client import Client
from sondalog.client.ala1 import Ala1Client
from sondalog.client.station_grammar import LIMITS
from sondalog.client.station_logger import Session, identify, read_command, read_values
from sondalog.client.station_schema import instances
from sondalog.collect.config import SourceConfig
from sondalog.collect.model import Reading
from sondalog.collect.sources import LoggerSource
from sondalog.collect.store_sqlite import SqliteStore

#: config_every -> the collector's CPU seconds per contact.
CPU: dict[int, list[float]] = {}
SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]


def serve(tmp: Path, protocol: str) -> tuple[subprocess.Popen[bytes], str]:
    proc = subprocess.Popen(
        [*SERVE, "--listen", "127.0.0.1:0", "--state", str(tmp / protocol), "--protocol",
         protocol, "--speed", "20"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 20)
    line = proc.stdout.readline().decode() if ready else ""
    if not line.startswith("listening on "):
        proc.kill()
        raise SystemExit(f"the logger did not start: {line!r}")
    url = f"tcp://127.0.0.1:{int(line.rsplit(':', 1)[1])}"
    with Client(url) as client:
        for command in (
            f"write date {time.strftime('%Y%m%d%H%M%S')}",
            "write channel max number 2",
            "write channel sampling period 000010 000010",
        ):
            assert client.command(command, timeout=10).ok, command
    return proc, url


async def _ignore(source: str, batch: list[Reading], cursor: str | None, **state: object) -> None:
    return None


async def contacts(url: str, store: Path, every: int, count: int) -> list[float]:
    config = SourceConfig(name=f"s{every}", url=url, config_every=every)
    sqlite = SqliteStore(store).open_sync()
    sqlite.add_source(config.name, url, "logger")
    source = LoggerSource(config, sqlite)
    times = []
    try:
        for _ in range(count):
            start = time.perf_counter()
            cpu = time.process_time()
            await source.poll(_ignore)
            times.append(time.perf_counter() - start)
            CPU.setdefault(every, []).append(time.process_time() - cpu)
    finally:
        sqlite.close_sync()
    return times


async def config_bytes(url: str) -> tuple[int, int, int]:
    """(settings, bytes sent, bytes received) of one whole read."""
    client = await Ala1Client.connect(url, timeout=5)
    try:
        session = Session(client)
        ident = await identify(session)
        values = await read_values(session, ident.version)
    finally:
        await client.close()
    wanted = instances(LIMITS[ident.version])
    sent = sum(len(read_command(s, n)) + 1 for s, n in wanted) + 25
    received = sum(len(v) + 2 for v in values.values()) + 4 * (sent // 120 + 2)
    return len(values), sent, received


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--contacts", type=int, default=30)
    args = parser.parse_args()
    logging.getLogger("sondalog").setLevel(logging.ERROR)  # no hints about the idle logger
    print("load average: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    with tempfile.TemporaryDirectory() as tmp:
        for protocol in ("2.10", "1.16"):
            proc, url = serve(Path(tmp), protocol)
            try:
                off: list[float] = []
                on: list[float] = []
                for _ in range(max(1, args.contacts // 10)):  # interleaved rounds
                    off += asyncio.run(contacts(url, Path(tmp) / f"{protocol}.sqlite", 0, 10))
                    on += asyncio.run(contacts(url, Path(tmp) / f"{protocol}.sqlite", 1, 10))
                settings, sent, received = asyncio.run(config_bytes(url))
            finally:
                proc.send_signal(signal.SIGTERM)
                proc.wait(timeout=10)
            print(f"protocol {protocol}: {settings} settings read per check")
            for name, times in (("without the check", off), ("with the check", on)):
                print(
                    f"  contact {name:18}: best {min(times) * 1000:7.1f} ms, "
                    f"median {statistics.median(times) * 1000:7.1f} ms"
                )
            cpu_off, cpu_on = (statistics.median(CPU.pop(k)) * 1000 for k in (0, 1))
            print(f"  collector CPU per contact (median): {cpu_off:.1f} ms -> {cpu_on:.1f} ms")
            added = statistics.median(on) - statistics.median(off)
            best = min(on) - min(off)
            print(f"  added per contact: best {best * 1000:.1f} ms, median {added * 1000:.1f} ms")
            line = max(sent, received) * 10 / 9600
            print(f"  bytes: {sent} sent, ~{received} received (>= {line:.0f} s at 9600 baud)")


if __name__ == "__main__":
    main()

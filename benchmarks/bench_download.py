"""Benchmark: ``sondalog logger download`` over a paced 115200 baud pty (goal >= 97 % of the
line's capacity).

1. Fills a logger's record through the pure core (12 channels every 100 s, ``record change
   0``) until ``read record status`` says FULL, with a ``file record size`` of ``--kib`` KiB;
2. serves it with ``sondalog logger serve --pty``;
3. sets ``com speed 115200`` and runs the download library into a CSV file over
   ``serial:///PTY?baud=115200``: ``read date``, the channel names, then verified chunks
   (``crcsum``, the oldest-row check, adaptive chunk size).

It prints the bytes received, the time from the first command to the last byte, and the line
share: the time the received bytes need at 10 bit times per byte, divided by the time taken.

Run: ``.venv/bin/python benchmarks/bench_download.py [--kib 256] [--baud 115200]``.
"""

from __future__ import annotations

import argparse
import asyncio
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sondalog.ala1 import Engine
from sondalog.app.logger import DATABASE_FILE, load_identity
from sondalog.backends.sim.logger import Analog, SimHardware
from sondalog.backends.sim.signals import sine
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.client import Client
from sondalog.collect.to_file import download_to_file

T0 = 1_000_000_000.0
SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]


def ask(engine: Engine, line: int, command: str, now: float) -> bytes:
    return b"".join(o.data for o in engine.receive(line, command.encode() + b"\r", now))


def fill_record(state: Path, kib: int) -> str:
    hw = SimHardware(analog=[Analog(16, sine(1.0, 0.8, 86400.0, 0.0, T0))])
    store = SqliteNvStore(load_identity(state) and state / DATABASE_FILE)
    engine = Engine(load_identity(state), store, T0, hw)
    line = engine.open_line()
    for command in (
        f"write file record size {kib * 1024}",
        "write date 20070101000000",
        "write channel max number 12",
    ):
        assert ask(engine, line, command, T0) == b"OK\r\n", command
    for ch in range(1, 13):
        for part in ("type 3", "address 16", "switch output 0", "format 0.3", "record change 0"):
            assert ask(engine, line, f"write channel {ch} {part}", T0) == b"OK\r\n", part
        ask(engine, line, f"write channel {ch} sampling start 20070101000000", T0)
        ask(engine, line, f"write channel {ch} sampling period 000100", T0)
    now = T0
    while b"FULL" not in (status := ask(engine, line, "read record status", now)):
        now += 3600
        engine.advance(now)
    for ch in range(1, 13):
        ask(engine, line, f"write channel {ch} sampling period 000000", now)
    store.close()
    return status.decode().split()[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kib", type=int, default=256, help="record size in KiB")
    parser.add_argument("--baud", type=int, default=115200)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        state = Path(tmp) / "state"
        status = fill_record(state, args.kib)
        print(f"record of {args.kib} KiB filled through the core ({status})")
        link = Path(tmp) / "ala1"
        proc = subprocess.Popen(
            [*SERVE, "--listen", "127.0.0.1:0", "--state", str(state), "--pty", str(link)],
            stdout=subprocess.PIPE,
        )
        try:
            assert proc.stdout is not None
            assert proc.stdout.readline().startswith(b"listening on ")
            with Client(f"serial://{link}?baud=9600") as client:
                assert client.command(f"write com speed {args.baud}").ok
            time.sleep(0.1)
            out = Path(tmp) / "record.csv"
            started = time.perf_counter()
            done = asyncio.run(download_to_file(f"serial://{link}?baud={args.baud}", out))
            elapsed = time.perf_counter() - started
            with Client(f"serial://{link}?baud={args.baud}") as client:
                client.command("write com speed 9600")
        finally:
            proc.send_signal(signal.SIGINT)
            proc.wait(timeout=10)
        theory = done.bytes * 10 / args.baud
        print(
            f"download at {args.baud} baud: {done.rows:,} rows, {done.bytes:,} bytes of record "
            f"answers in {elapsed:.2f} s (line time {theory:.2f} s), {done.rereads} re-reads"
        )
        print(f"line share: {theory / elapsed:.2%} (goal >= 97 %)")


if __name__ == "__main__":
    main()

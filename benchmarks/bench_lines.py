"""Benchmark: downloading the record over a paced pty (issue 4, "Lines").

1. Fills a logger's 1 MiB record quickly through the pure core (12 channels sampled every
   100 s, ``record change 0``, module time stepped a day at a time until ``read record
   status`` says FULL), in a state directory;
2. serves that directory with ``sondalog logger serve --pty``;
3. for each rate, sets ``com speed`` (the host follows after the ``OK``) and downloads with
   ``read record N from start``, timing the bytes from the first read to the last.

It prints, per rate, the bytes, the time and the line efficiency: the theoretical time (10
bit times per byte, 8N1) divided by the measured time (target >= 97 %). The full MiB takes
~18 min at 9600 baud, so there only ``--rows-9600`` rows are read (default 1000, ~100 kB).

Run: ``.venv/bin/python benchmarks/bench_lines.py [--rows-9600 N] [--rows-fast N]``.
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import subprocess
import sys
import tempfile
import termios
import time
import tty
from pathlib import Path

from sondalog.ala1 import Engine
from sondalog.app.logger import DATABASE_FILE, load_identity
from sondalog.backends.sim.logger import Analog, SimHardware
from sondalog.backends.sim.signals import sine
from sondalog.backends.store.ala1_nv import SqliteNvStore

T0 = 1_000_000_000.0
SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]


def ask(engine: Engine, line: int, command: str, now: float) -> bytes:
    return b"".join(o.data for o in engine.receive(line, command.encode() + b"\r", now))


def fill_record(state: Path) -> str:
    """A full record in ``state``; returns ``read record status``."""
    hw = SimHardware(analog=[Analog(16, sine(1.0, 0.8, 86400.0, 0.0, T0))])
    identity = load_identity(state)  # creates the state directory
    store = SqliteNvStore(state / DATABASE_FILE)
    engine = Engine(identity, store, T0, hw)
    line = engine.open_line()
    for command in ("write date 20070101000000", "write channel max number 12"):
        assert ask(engine, line, command, T0) == b"OK\r\n"
    for ch in range(1, 13):
        for part in (
            "type 3",
            "address 16",
            "switch output 0",
            "format 0.3",
            "sampling period 000100",
            "sampling start 20070101000000",
            "record change 0",
        ):
            assert ask(engine, line, f"write channel {ch} {part}", T0) == b"OK\r\n", part
    now = T0
    while "FULL" not in (status := ask(engine, line, "read record status", now).decode()):
        now += 86400
        engine.advance(now)
    for ch in range(1, 13):  # stop sampling: the download reads a fixed record
        ask(engine, line, f"write channel {ch} record change 1000", now)
    store.close()
    return status.split()[0]


class Host:
    """The host end: the pty symlink opened raw at a given rate."""

    def __init__(self, path: Path) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)

    def speed(self, baud: int) -> None:
        attrs = termios.tcgetattr(self.fd)
        attrs[2] &= ~(termios.IXON | termios.IXOFF)
        attrs[4] = attrs[5] = getattr(termios, f"B{baud}")
        termios.tcsetattr(self.fd, termios.TCSANOW, attrs)

    def ask(self, command: bytes, timeout: float = 3600.0) -> tuple[bytes, float, int, float]:
        """Answer bytes, time of the first read, bytes in it, time of the last read."""
        os.write(self.fd, command + b"\r")
        buf = bytearray()
        first_at, first_size, last_at = 0.0, 0, 0.0
        deadline = time.monotonic() + timeout
        while not (buf.endswith(b"OK\r\n") or buf.endswith(b"ERROR\r\n")):
            if not select.select([self.fd], [], [], max(0.0, deadline - time.monotonic()))[0]:
                raise TimeoutError(bytes(buf[-200:]))
            chunk = os.read(self.fd, 65536)
            last_at = time.monotonic()
            if not buf:
                first_at, first_size = last_at, len(chunk)
            buf += chunk
        return bytes(buf), first_at, first_size, last_at


def download(host: Host, baud: int, rows: int) -> None:
    if baud != 9600:
        answer = host.ask(f"write com speed {baud}".encode())[0]
        assert answer == b"OK\r\n", answer
        time.sleep(0.05)
        host.speed(baud)
    data, first_at, first_size, last_at = host.ask(f"read record {rows} from start".encode())
    measured = last_at - first_at
    theory = (len(data) - first_size) * 10 / baud
    print(
        f"  {baud:>6} baud  read record {rows:>6} from start: {len(data):>9,} bytes"
        f"  {measured:8.2f} s  (theory {theory:8.2f} s)  efficiency {theory / measured:7.2%}"
    )
    sys.stdout.flush()
    if baud != 9600:
        assert host.ask(b"write com speed 9600")[0] == b"OK\r\n"
        time.sleep(0.05)
        host.speed(9600)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows-9600", type=int, default=1000)
    parser.add_argument("--rows-fast", type=int, default=100000, help="at 115200 and 230400")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        state = Path(tmp) / "state"
        started = time.perf_counter()
        status = fill_record(state)
        print(
            f"record filled through the core (status {status}) in "
            f"{time.perf_counter() - started:.1f} s"
        )
        link = Path(tmp) / "ala1"
        proc = subprocess.Popen(
            [*SERVE, "--listen", "127.0.0.1:0", "--state", str(state), "--pty", str(link)],
            stdout=subprocess.PIPE,
        )
        try:
            assert proc.stdout is not None
            assert proc.stdout.readline().startswith(b"listening on ")
            host = Host(link)
            host.speed(9600)
            print("download over a paced pty (first to last byte):")
            download(host, 9600, args.rows_9600)
            for baud in (115200, 230400):
                download(host, baud, args.rows_fast)
            os.close(host.fd)
        finally:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=10)


if __name__ == "__main__":
    main()

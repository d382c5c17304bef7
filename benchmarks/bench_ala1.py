"""Commands per second of the ALA1 logger: pure engine vs. TCP on loopback.

Not a test (DESIGN.md "Benchmarks"): prints figures and ratios. Run with
``.venv/bin/python benchmarks/bench_ala1.py [--seconds S]``.

- engine: ``Engine.receive`` called directly (SQLite store in a temp dir, protocol 2.10).
- tcp pipelined: one connection, commands sent in batches without waiting for answers.
- tcp 50 clients: 50 connections, each sending one command and waiting for its answer.

The TCP server is a real ``sondalog logger serve`` subprocess; the clients run in this
process (one asyncio loop), so the TCP figures include the client's own cost.
"""

from __future__ import annotations

import argparse
import asyncio
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sondalog.ala1 import Engine, Identity
from sondalog.backends.store.ala1_nv import SqliteNvStore

COMMANDS: dict[str, bytes] = {
    "read date": b"read date\r",
    "read channel name (12)": b"read channel name\r",
    "5-command chained line": (
        b"read date read i version read channel 1 name read com speed read record status\r"
    ),
}
SETUP = b"write channel max number 12\r"
CLIENTS = 50
SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]
BATCH = 200


def bench_engine(command: bytes, seconds: float, state: Path) -> float:
    store = SqliteNvStore(state / "engine.sqlite")
    engine = Engine(Identity(), store, time.time())
    line = engine.open_line()
    engine.receive(line, SETUP, time.time())
    count = 0
    start = time.perf_counter()
    end = start + seconds
    while time.perf_counter() < end:
        for _ in range(100):
            engine.receive(line, command, time.time())
        count += 100
    elapsed = time.perf_counter() - start
    store.close()
    return count / elapsed


async def _answer_length(host: str, port: int, command: bytes) -> int:
    reader, writer = await asyncio.open_connection(host, port)
    writer.write(command)
    data = await reader.readuntil(b"OK\r\n")
    writer.close()
    return len(data)


async def bench_pipelined(host: str, port: int, command: bytes, seconds: float) -> float:
    size = await _answer_length(host, port, command)
    reader, writer = await asyncio.open_connection(host, port)
    count = 0
    start = time.perf_counter()
    end = start + seconds
    while time.perf_counter() < end:
        writer.write(command * BATCH)
        await reader.readexactly(size * BATCH)
        count += BATCH
    elapsed = time.perf_counter() - start
    writer.close()
    return count / elapsed


async def bench_concurrent(host: str, port: int, command: bytes, seconds: float) -> float:
    size = await _answer_length(host, port, command)
    counts = [0] * CLIENTS
    end = time.perf_counter() + seconds

    async def client(index: int) -> None:
        reader, writer = await asyncio.open_connection(host, port)
        while time.perf_counter() < end:
            writer.write(command)
            await reader.readexactly(size)
            counts[index] += 1
        writer.close()

    start = time.perf_counter()
    await asyncio.gather(*(client(i) for i in range(CLIENTS)))
    return sum(counts) / (time.perf_counter() - start)


def start_server(state: Path) -> tuple[subprocess.Popen[bytes], str, int]:
    proc = subprocess.Popen(
        [*SERVE, "--listen", "127.0.0.1:0", "--state", str(state)],
        stdout=subprocess.PIPE,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline().decode()
    host, _, port = line.removeprefix("listening on ").strip().rpartition(":")
    return proc, host, int(port)


async def setup_server(host: str, port: int) -> None:
    reader, writer = await asyncio.open_connection(host, port)
    writer.write(SETUP)
    assert await reader.readuntil(b"\r\n") == b"OK\r\n"
    writer.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="per measurement")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        state = Path(tmp)
        proc, host, port = start_server(state / "served")
        try:
            asyncio.run(setup_server(host, port))
            print(f"ALA1 commands per second ({args.seconds:g} s each, protocol 2.10)")
            header = f"{'command':<24}{'engine':>10}{'tcp pipe':>10}{'tcp x50':>10}"
            print(header + f"{'pipe/eng':>10}{'x50/eng':>10}")
            for name, command in COMMANDS.items():
                engine = bench_engine(command, args.seconds, state)
                pipe = asyncio.run(bench_pipelined(host, port, command, args.seconds))
                many = asyncio.run(bench_concurrent(host, port, command, args.seconds))
                print(
                    f"{name:<24}{engine:>10.0f}{pipe:>10.0f}{many:>10.0f}"
                    f"{pipe / engine:>10.2f}{many / engine:>10.2f}"
                )
        finally:
            proc.terminate()
            proc.wait(timeout=10)


if __name__ == "__main__":
    main()

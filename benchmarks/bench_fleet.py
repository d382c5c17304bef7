"""A fleet of virtual loggers in one process (issue 11): CPU share, memory, answer latency.

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_fleet.py [--loggers 1000] [--seconds 120] [--quick]``.

1. A site file declares ``--loggers`` loggers as one numbered range (``[[loggers]]`` with
   ``count``, every port chosen free); ``sondalog serve`` runs them in one process (its
   default event loop: uvloop when installed; ``--loop asyncio`` for the standard one).
2. Through the protocol, every logger gets ``--channels`` channels (the supply, no switch)
   sampling every 60 s; the rows of each sampling instant are group-committed.
3. For ``--seconds`` a client polls ``--poll`` of the loggers with ``read i version``, each
   once a second, and measures the latency of every answer.

Prints: start-up time to the last "listening" line, setup time, the server's CPU share of one
core over the window (``/proc/PID/stat``; goal <= 25 %), its RSS at the end and its peak
(goal <= 400 MB), and the poll latency median / p99 (goal: median <= 50 ms).
"""

from __future__ import annotations

import argparse
import asyncio
import os
import select
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HOST = "127.0.0.1"
TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime + stime


def memory_mb(pid: int) -> tuple[float, float]:
    """(RSS, peak RSS) in MB."""
    values = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, rest = line.partition(":")
        if key in ("VmRSS", "VmHWM"):
            values[key] = int(rest.split()[0]) / 1024
    return values["VmRSS"], values["VmHWM"]


def start(count: int, work: Path, loop: str) -> tuple[subprocess.Popen[bytes], list[int], float]:
    site = work / "fleet.toml"
    site.write_text(
        f'[[loggers]]\ncount = {count}\nserial_number = "F{{n:05}}"\nlisten = "{HOST}:0"\n'
    )
    env = {**os.environ, "SONDALOG_LOOP": loop}
    began = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(work / "state")],
        stdout=subprocess.PIPE,
        stderr=open(work / "serve.log", "wb"),  # noqa: SIM115 - closed with the process
        env=env,
    )
    assert proc.stdout is not None
    ports: list[int] = []
    while len(ports) < count:
        ready, _, _ = select.select([proc.stdout], [], [], 120)
        line = proc.stdout.readline().decode() if ready else ""
        if not line.startswith("logger "):
            proc.kill()
            sys.exit(f"serve failed: {line!r}\n{(work / 'serve.log').read_text()[-2000:]}")
        ports.append(int(line.rsplit(":", 1)[1]))
    return proc, ports, time.perf_counter() - began


async def ask(port: int, lines: list[bytes]) -> None:
    reader, writer = await asyncio.open_connection(HOST, port)
    try:
        for line in lines:
            writer.write(line)
            answer = await reader.readuntil(b"\r\n")
            while answer not in (b"OK\r\n", b"ERROR\r\n"):
                answer = await reader.readuntil(b"\r\n")
            if answer != b"OK\r\n":
                raise RuntimeError(f"port {port} refused {line!r}")
    finally:
        writer.close()


async def record_status(port: int) -> str:
    reader, writer = await asyncio.open_connection(HOST, port)
    writer.write(b"read record status\r")
    answer = await reader.readuntil(b"OK\r\n")
    writer.close()
    return answer.decode().split()[0]


async def configure(ports: list[int], channels: int) -> None:
    # output 1 powers the supply divider (§6.7.3): on for good, so no channel switches it
    lines = [f"write channel max number {channels} write output 1 value 1\r".encode()]
    for ch in range(1, channels + 1):
        lines.append(
            f"write channel {ch} type 1 write channel {ch} switch output 0 "
            f"write channel {ch} sampling period 000100\r".encode()
        )
        lines.append(f"write channel {ch} sampling start 20000101000000\r".encode())
    gate = asyncio.Semaphore(50)

    async def one(port: int) -> None:
        async with gate:
            await ask(port, lines)

    await asyncio.gather(*(one(port) for port in ports))


async def poll(ports: list[int], seconds: float) -> list[float]:
    latencies: list[float] = []
    end = time.perf_counter() + seconds

    async def client(port: int, offset: float) -> None:
        reader, writer = await asyncio.open_connection(HOST, port)
        await asyncio.sleep(offset)
        while time.perf_counter() < end:
            sent = time.perf_counter()
            writer.write(b"read i version\r")
            await reader.readuntil(b"OK\r\n")
            latencies.append(time.perf_counter() - sent)
            await asyncio.sleep(max(0.0, 1.0 - (time.perf_counter() - sent)))
        writer.close()

    step = 1.0 / max(1, len(ports))
    await asyncio.gather(*(client(port, i * step) for i, port in enumerate(ports)))
    return latencies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loggers", type=int, default=1000)
    parser.add_argument("--channels", type=int, default=4)
    parser.add_argument("--poll", type=int, default=100, help="loggers polled once a second")
    parser.add_argument("--seconds", type=float, default=120.0, help="measuring window")
    parser.add_argument("--loop", choices=("auto", "asyncio", "uvloop"), default="auto")
    parser.add_argument("--quick", action="store_true", help="100 loggers, a 65 s window")
    args = parser.parse_args()
    if args.quick:
        args.loggers, args.seconds, args.poll = 100, 65.0, min(args.poll, 100)
    load = os.getloadavg()[0]
    print(f"{os.cpu_count()} CPUs, load average {load:.2f}; python {sys.version.split()[0]}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        proc, ports, started = start(args.loggers, work, args.loop)
        try:
            maps = Path(f"/proc/{proc.pid}/maps").read_text()
            loop = "uvloop" if "/uvloop/" in maps else "asyncio"
            began = time.perf_counter()
            asyncio.run(configure(ports, args.channels))
            setup = time.perf_counter() - began
            cpu0, t0 = cpu_seconds(proc.pid), time.perf_counter()
            latencies = asyncio.run(poll(ports[: args.poll], args.seconds))
            cpu1, t1 = cpu_seconds(proc.pid), time.perf_counter()
            rss, peak = memory_mb(proc.pid)
            status = asyncio.run(record_status(ports[-1]))
        finally:
            proc.terminate()
            proc.wait(timeout=60)
        share = (cpu1 - cpu0) / (t1 - t0)
        latencies.sort()
        median = statistics.median(latencies) * 1000
        p99 = latencies[int(len(latencies) * 0.99) - 1] * 1000
        rows = args.loggers * args.channels * (t1 - t0) / 60
        print(
            f"{args.loggers} loggers x {args.channels} channels every 60 s, one process "
            f"({loop}); {args.poll} polled once a second for {t1 - t0:.0f} s"
        )
        print("| figure | value | goal |")
        print("|---|---|---|")
        print(f"| start-up to the last listening line | {started:.1f} s | |")
        print(f"| setup through the protocol | {setup:.1f} s | |")
        print(f"| server CPU, share of one core | {share * 100:.1f} % | <= 25 % |")
        print(f"| RSS at the end / peak | {rss:.0f} / {peak:.0f} MB | <= 400 MB |")
        print(
            f"| `read i version` latency median / p99 | {median:.1f} / {p99:.1f} ms "
            f"({len(latencies)} answers) | median <= 50 ms |"
        )
        print(f"| channel samples in the window (about) | {rows:,.0f} | |")
        print(f"| `read record status` of the last logger (bytes used, %, state) | {status} | |")


if __name__ == "__main__":
    main()

"""Benchmark: what a wake of the event loop costs a client of many short connections (issue 24).

A client process (uvloop, as the collector) opens ``--rate`` connections a second to a
trivial server (another process: one line in, 300 bytes and ``OK`` out, closed), each
connection a task, for ``--seconds``; its CPU time (``time.process_time``) and its voluntary
context switches (each a sleep of the process: the loop found nothing to do) a connection.
The connections are due at an even pace; ``--ticks`` lists the grids they start on: 0 is each
connection at its own instant (its own timer, as the collector's sources were before the
seventh round), 0.1 and 1 start the connections due within a step together
(``sondalog.collect.ticks``). The runs of the ticks are interleaved, ``--runs`` times.

The work a connection is the same in every run; what differs is how often the process goes
to sleep and is woken. On a quiet machine each wake of an idle process costs far more CPU
than the loop's own iteration (the kernel's wake-up, the caches refilled), the pattern the
collector's fleet runs showed (the same tree 0.49-0.9 ms a contact on a busy machine, 1.2-1.4
ms on a quiet one).

    .venv/bin/python benchmarks/bench_loop_wakes.py --runs 3 --seconds 10
"""

from __future__ import annotations

import argparse
import asyncio
import math
import os
import statistics
import subprocess
import sys
import time

ANSWER = b"x" * 300 + b"\r\nOK\r\n"


async def serve(port: int) -> None:
    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await reader.readline()
        writer.write(ANSWER)
        await writer.drain()
        writer.close()

    server = await asyncio.start_server(handle, "127.0.0.1", port, backlog=4096)
    print(server.sockets[0].getsockname()[1], flush=True)
    await asyncio.Event().wait()


async def one(port: int) -> None:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(b"read\r\n")
    await reader.readuntil(b"OK\r\n")
    writer.close()


def sleeps() -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("voluntary_ctxt_switches"):
                return int(line.split()[1])
    return 0


async def client(port: int, rate: float, tick: float, seconds: float) -> tuple[float, float]:
    """CPU ms and sleeps a connection."""
    loop = asyncio.get_running_loop()
    tasks: set[asyncio.Task[None]] = set()
    began, cpu, slept = loop.time(), time.process_time(), sleeps()
    n = 0
    while n < rate * seconds:
        due = began + n / rate
        at = math.ceil(due / tick) * tick if tick else due
        await asyncio.sleep(max(0.0, at - loop.time()))
        while n < rate * seconds and began + n / rate <= max(loop.time(), at):
            task = asyncio.create_task(one(port))
            tasks.add(task)
            task.add_done_callback(tasks.discard)
            n += 1
    await asyncio.gather(*tasks)
    return (time.process_time() - cpu) / n * 1e3, (sleeps() - slept) / n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=167.0, help="connections a second")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--ticks", type=float, nargs="+", default=[0.0, 0.1, 1.0])
    parser.add_argument("--_serve", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--_client", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--_tick", type=float, default=0.0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    import uvloop

    if args._serve:
        uvloop.run(serve(0))
        return
    if args._client:
        ms, slept = uvloop.run(client(args._client, args.rate, args._tick, args.seconds))
        print(f"{ms} {slept}")
        return
    server = subprocess.Popen(
        [sys.executable, __file__, "--_serve"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert server.stdout is not None
        port = int(server.stdout.readline())
        print(f"{os.cpu_count()} CPUs, {args.rate:g} connections/s for {args.seconds:g} s")
        found: dict[float, list[tuple[float, float, float]]] = {t: [] for t in args.ticks}
        for index in range(args.runs):
            for tick in args.ticks if index % 2 == 0 else args.ticks[::-1]:
                run = [sys.executable, __file__, f"--_client={port}", f"--_tick={tick}"]
                run += [f"--rate={args.rate}", f"--seconds={args.seconds}"]
                out = subprocess.run(run, capture_output=True, text=True, check=True).stdout
                ms, slept = map(float, out.split())
                load = os.getloadavg()[0]
                found[tick].append((ms, slept, load))
                print(
                    f"  tick {tick:g} s: {ms:.3f} ms CPU, {slept:.2f} sleeps a connection, "
                    f"load {load:.2f}",
                    flush=True,
                )
    finally:
        server.terminate()
        server.wait()
    print("| tick s | ms CPU a connection (best / median) | sleeps a connection | load |")
    print("|---|---|---|---|")
    for tick, runs in found.items():
        cpu = sorted(r[0] for r in runs)
        print(
            f"| {tick:g} | {cpu[0]:.3f} / {statistics.median(cpu):.3f} "
            f"| {statistics.median(r[1] for r in runs):.2f} "
            f"| {min(r[2] for r in runs):.1f}-{max(r[2] for r in runs):.1f} |"
        )


if __name__ == "__main__":
    main()

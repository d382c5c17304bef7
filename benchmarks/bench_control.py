"""The control API (issue 23): snapshot/restore of a full logger; answers under a fleet.

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_control.py [--loggers 1000] [--requests 500] [--quick]``.

1. **Snapshot/restore** (goal < 50 ms). A served site's logger (``[logger]``, state on disk)
   samples the supply every second until its cyclic record is full (the step of the control
   API, in-process). Then, over the HTTP API on loopback: ``snapshot`` of the full logger; a
   "test" steps 10 minutes (600 new rows, the oldest dropped) and ``restore`` puts the
   snapshot back (the usual reset between tests); and a restore after the whole record was
   rewritten (the worst case: no row of the snapshot left). Each is timed from the request
   to its answer, ``--repeats`` times.
2. **Answers under a fleet** (goal: median < 5 ms). ``sondalog serve FLEET --control``
   runs ``--loggers`` loggers with 4 channels sampling every 60 s (bench_fleet.py's fleet;
   ``--speed 60``: every second); a client sends ``--requests`` requests
   (``GET /devices/NAME``, ``POST .../set``, ``GET /time``, in turn) on one keep-alive
   connection and times each answer.

Prints best, median and p99 of each.
"""

from __future__ import annotations

import argparse
import asyncio
import http.client
import json
import os
import select
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_fleet import configure  # (the same fleet set-up; benchmarks/ is on sys.path)
from sondalog.app.control_api import start_control
from sondalog.app.serve import start_site
from sondalog.app.site import load_site
from sondalog.io.clock_control import ControlledClock

HOST = "127.0.0.1"
SITE = """
[logger]
supply = { model = "sine", mean = 12.0, amplitude = 1.0, period = 86400 }
[logger.serve]
listen = "127.0.0.1:0"
"""
SETUP = (
    "write date 20240101000000 write output 1 value 1",
    "write channel max number 1 write channel 1 type 1 write channel 1 switch output 0",
    "write channel 1 format 0.2 write channel 1 record change 0",
    "write channel 1 sampling period 000001 write channel 1 sampling start 20240101000001",
)


class Api:
    """A keep-alive HTTP/1.1 connection to the control API."""

    def __init__(self, port: int) -> None:
        self.conn = http.client.HTTPConnection(HOST, port, timeout=60)
        self.cpu = 0.0  # the CPU time the whole process spent during the last call

    def call(self, method: str, path: str, body: object = None) -> tuple[float, object]:
        data = None if body is None else json.dumps(body).encode()
        headers = {"Content-Type": "application/json"} if data is not None else {}
        began, cpu = time.perf_counter(), time.process_time()
        self.conn.request(method, path, data, headers)
        response = self.conn.getresponse()
        payload = response.read()
        took = time.perf_counter() - began
        self.cpu = time.process_time() - cpu
        if response.status != 200:
            raise RuntimeError(f"{method} {path}: {response.status} {payload[:200]!r}")
        return took, json.loads(payload)


def figures(name: str, seconds: list[float], goal: str) -> None:
    ms = sorted(s * 1000 for s in seconds)
    p99 = ms[max(0, int(len(ms) * 0.99) - 1)]
    print(
        f"| {name} | {ms[0]:.1f} | {statistics.median(ms):.1f} | {p99:.1f} | {len(ms)} | {goal} |"
    )


async def _send(port: int, line: str) -> str:
    reader, writer = await asyncio.open_connection(HOST, port)
    writer.write(line.encode() + b"\r")
    answer = b""
    while not answer.endswith((b"OK\r\n", b"ERROR\r\n")):
        answer += await reader.readuntil(b"\r\n")
    writer.close()
    if answer.endswith(b"ERROR\r\n"):
        raise RuntimeError(f"{line!r} refused")
    return answer.decode()


async def snapshot_restore(work: Path, repeats: int) -> None:
    path = work / "site.toml"
    path.write_text(SITE)
    clock = ControlledClock(1.0, start=1_700_000_000.0, paused=True)
    running = await start_site(load_site(path), work / "state", clock)
    server = await start_control(running, clock, HOST, 0)
    assert running.logger is not None
    port = running.logger.servers[0].address[1]
    api = Api(server.address[1])

    async def call(method: str, path: str, body: object = None) -> tuple[float, object]:
        return await asyncio.to_thread(api.call, method, path, body)

    try:
        for line in SETUP:
            await _send(port, line)
        filled = time.perf_counter()
        rows = 0
        while True:  # until the cyclic record drops rows: full
            await call("POST", "/time/step", {"seconds": 3600})
            _, device = await call("GET", "/devices/logger")
            assert isinstance(device, dict)
            if device["record_rows"] <= rows:
                break
            rows = device["record_rows"]
        status = (await _send(port, "read record status")).split()[0]
        print(
            f"full record: {rows} rows, `read record status` {status}, "
            f"filled in {time.perf_counter() - filled:.1f} s"
        )
        snaps, resets, worst = [], [], []
        cpu: dict[str, list[float]] = {"snapshot": [], "restore": [], "worst": []}
        for _ in range(repeats):
            took, _ = await call("POST", "/devices/logger/snapshot", {"name": "full"})
            snaps.append(took)
            cpu["snapshot"].append(api.cpu)
        for _ in range(repeats):
            await call("POST", "/time/step", {"seconds": 600})  # a test: 600 new rows
            took, answer = await call("POST", "/devices/logger/restore", {"name": "full"})
            resets.append(took)
            cpu["restore"].append(api.cpu)
        for _ in range(repeats):
            await call("POST", "/time/step", {"seconds": rows + 100})  # every row rewritten
            took, answer = await call("POST", "/devices/logger/restore", {"name": "full"})
            worst.append(took)
            cpu["worst"].append(api.cpu)
        assert isinstance(answer, dict) and answer["record_rows"] == rows
        print("| over HTTP | best ms | median ms | p99 ms | n | goal |")
        print("|---|---|---|---|---|---|")
        figures("snapshot of the full logger", snaps, "< 50 ms")
        figures("restore after a test (600 rows differ)", resets, "< 50 ms")
        figures("restore after the whole record changed", worst, "< 50 ms")
        spent = ", ".join(f"{k} {statistics.median(v) * 1000:.1f} ms" for k, v in cpu.items())
        print(f"CPU of the process (server and client) a call, median: {spent}")
    finally:
        await server.stop()
        await running.close()


def fleet(work: Path, count: int, requests: int, speed: float) -> None:
    site = work / "fleet.toml"
    site.write_text(
        f'[[loggers]]\ncount = {count}\nserial_number = "F{{n:05}}"\nlisten = "{HOST}:0"\n'
    )
    command = [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(work / "s")]
    command += ["--speed", str(speed), "--control", f"{HOST}:0"]
    log = open(work / "serve.log", "wb")  # noqa: SIM115 - closed with the process
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=log)
    assert proc.stdout is not None
    ports: list[int] = []
    api_port = 0
    try:
        while not api_port:
            ready, _, _ = select.select([proc.stdout], [], [], 180)
            line = proc.stdout.readline().decode() if ready else ""
            if line.startswith("logger "):
                ports.append(int(line.rsplit(":", 1)[1]))
            elif line.startswith("control API on "):
                api_port = int(line.rsplit(":", 1)[1])
            else:
                sys.exit(f"serve failed: {line!r}\n{(work / 'serve.log').read_text()[-2000:]}")
        asyncio.run(configure(ports, 4))
        time.sleep(2.0)
        api = Api(api_port)
        names = [f"loggers.F{n:05}" for n in range(1, count + 1)]
        took: dict[str, list[float]] = {
            "GET /devices/NAME": [],
            "POST /devices/NAME/set": [],
            "GET /time": [],
        }
        for i in range(requests):
            name = names[(i * 7919) % count]
            if i % 3 == 0:
                took["GET /devices/NAME"].append(api.call("GET", f"/devices/{name}")[0])
            elif i % 3 == 1:
                body = {"input": "supply", "value": 12.0 + (i % 10) / 10}
                took["POST /devices/NAME/set"].append(
                    api.call("POST", f"/devices/{name}/set", body)[0]
                )
            else:
                took["GET /time"].append(api.call("GET", "/time")[0])
        every = [t for times in took.values() for t in times]
        rate = 4 * count * speed / 60
        print(
            f"{count} loggers x 4 channels every 60 s at --speed {speed:g} ({rate:.0f} samples/s)"
        )
        print("| control API answer | best ms | median ms | p99 ms | n | goal |")
        print("|---|---|---|---|---|---|")
        for name, times in took.items():
            figures(name, times, "")
        figures("all requests", every, "median < 5 ms")
    finally:
        proc.terminate()
        proc.wait(timeout=300)  # (a thousand loggers close their servers and the database)
        log.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loggers", type=int, default=1000)
    parser.add_argument("--requests", type=int, default=600)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--speed", type=float, default=1.0, help="the fleet's --speed")
    parser.add_argument("--fleet-only", action="store_true", help="skip snapshot/restore")
    parser.add_argument("--restore-only", action="store_true", help="skip the fleet")
    parser.add_argument("--quick", action="store_true", help="100 loggers, fewer repeats")
    args = parser.parse_args()
    if args.quick:
        args.loggers, args.requests, args.repeats = 100, 150, 8
    load = os.getloadavg()[0]
    print(f"{os.cpu_count()} CPUs, load average {load:.2f}; python {sys.version.split()[0]}")
    if not args.fleet_only:
        with tempfile.TemporaryDirectory() as tmp:
            asyncio.run(snapshot_restore(Path(tmp), args.repeats))
    if not args.restore_only:
        with tempfile.TemporaryDirectory() as tmp:
            fleet(Path(tmp), args.loggers, args.requests, args.speed)


if __name__ == "__main__":
    main()

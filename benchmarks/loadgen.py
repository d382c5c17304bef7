"""The client side of the server benchmarks: many TCP clients on loopback, in their own process.

Not a benchmark by itself (``make bench`` runs only ``bench_*.py``). One :class:`Job` drives
one server with ``clients`` connections, each sending one request and waiting for its answer:

- ``closed``: every client sends its next request as soon as the answer is complete
  (requests per second; near the floor the client process, not the server, is the limit);
- ``fixed``: the clients together offer ``rate`` requests per second on a fixed schedule
  (each client every ``clients / rate`` seconds, staggered); a client whose answer arrives
  late sends at once and the schedule does not catch up, so a server that cannot keep up
  shows an achieved rate below the offered one.

The server's CPU time over the measuring window comes from ``/proc`` (all threads; see
:func:`process_cpu`), read by the client process at the window's edges. The clients are
plain ``asyncio.Protocol`` callbacks (no streams, no tasks per request) so that the client
costs as little as possible; the server under test is never in this process.

:func:`run_jobs` runs the jobs in a separate process (``multiprocessing`` spawn) so that
the clients do not share a GIL with the caller.
"""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import struct
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Literal, cast

Kind = Literal["line", "modbus"]
Mode = Literal["closed", "fixed"]
TICKS = os.sysconf("SC_CLK_TCK")


@dataclass(frozen=True)
class Request:
    """What a client sends: an ALA1 line (answer ends ``OK\\r\\n``) or a Modbus/TCP read."""

    kind: Kind
    line: bytes = b""  # kind "line": the command with its CR
    address: int = 0  # kind "modbus": read holding registers (function 3)
    count: int = 1
    unit: int = 1

    def payload(self, tid: int) -> bytes:
        if self.kind == "line":
            return self.line
        return struct.pack(">HHHBBHH", tid & 0xFFFF, 0, 6, self.unit, 3, self.address, self.count)


@dataclass(frozen=True)
class Job:
    host: str
    port: int
    pid: int  # the server process, for its CPU time
    request: Request
    mode: Mode
    seconds: float  # measuring window
    warmup: float
    clients: int = 50
    rate: float = 4000.0  # mode "fixed": offered requests per second, all clients together


@dataclass(frozen=True)
class Result:
    requests: int  # answers completed inside the window
    errors: int  # error answers (ALA1 ERROR, Modbus exception) inside the window
    dropped: int  # connections the server closed before the end
    elapsed: float  # window length, seconds
    server_cpu: float  # server CPU seconds in the window
    client_cpu: float  # this client process's CPU seconds in the window
    latencies: tuple[float, ...]  # mode "fixed": seconds from send to complete answer

    @property
    def rate(self) -> float:
        return self.requests / self.elapsed

    @property
    def us_per_request(self) -> float:
        return self.server_cpu / self.requests * 1e6 if self.requests else float("inf")


def process_cpu(pid: int) -> float:
    """CPU seconds (user + system, all threads) the process has used so far.

    From ``/proc/<pid>/task/*/schedstat`` (nanoseconds on the CPU, exact) where the kernel
    has it; else from ``/proc/<pid>/stat`` utime + stime, which counts clock ticks (10 ms):
    too coarse for a server that is idle most of a short window.
    """
    try:
        return schedstat_cpu(pid)
    except (OSError, ValueError):
        return stat_cpu(pid)


def schedstat_cpu(pid: int) -> float:
    total = 0
    for task in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{task}/schedstat", "rb") as f:
            total += int(f.read().split()[0])
    return total / 1e9


def stat_cpu(pid: int) -> float:
    with open(f"/proc/{pid}/stat", "rb") as f:
        stat = f.read()
    fields = stat[stat.rindex(b")") + 2 :].split()
    return (int(fields[11]) + int(fields[12])) / TICKS  # fields 14 and 15 of proc(5)


class _Shared:
    """Counters of one job, updated by every client's callbacks (one thread)."""

    def __init__(self, job: Job) -> None:
        self.job = job
        self.loop = asyncio.get_running_loop()
        self.counting = False
        self.stopped = False
        self.requests = 0
        self.errors = 0
        self.dropped = 0
        self.latencies: list[float] = []
        self.period = job.clients / job.rate


class _Client(asyncio.Protocol):
    def __init__(self, shared: _Shared) -> None:
        self._shared = shared
        self._request = shared.job.request
        self._modbus = self._request.kind == "modbus"
        self._transport: asyncio.Transport | None = None
        self._buffer = b""
        self._tid = 0
        self._sent_at = 0.0
        self._next = 0.0
        self.lost = asyncio.get_running_loop().create_future()

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # uvloop's transports are not subclasses of asyncio.Transport: no isinstance check
        self._transport = cast(asyncio.Transport, transport)

    def connection_lost(self, exc: Exception | None) -> None:
        if not self._shared.stopped:
            self._shared.dropped += 1
        if not self.lost.done():
            self.lost.set_result(None)

    def start(self, at: float) -> None:
        """Send the first request at loop time ``at`` (now for closed loop)."""
        self._next = at
        self._shared.loop.call_at(at, self._send)

    def _send(self) -> None:
        if self._shared.stopped or self._transport is None or self._transport.is_closing():
            return
        self._tid += 1
        self._sent_at = self._shared.loop.time()
        self._transport.write(self._request.payload(self._tid))

    def data_received(self, data: bytes) -> None:
        buffer = self._buffer + data if self._buffer else data
        if self._modbus:
            if len(buffer) < 6 or len(buffer) < 6 + int.from_bytes(buffer[4:6], "big"):
                self._buffer = buffer
                return
            error = len(buffer) < 8 or buffer[7] & 0x80 != 0 or buffer[:2] != self._tid_bytes()
        else:
            if buffer.endswith(b"OK\r\n"):
                error = False
            elif buffer.endswith(b"ERROR\r\n"):
                error = True
            else:
                self._buffer = buffer
                return
        self._buffer = b""
        self._done(error)

    def _tid_bytes(self) -> bytes:
        return (self._tid & 0xFFFF).to_bytes(2, "big")

    def _done(self, error: bool) -> None:
        shared = self._shared
        now = shared.loop.time()
        if shared.counting:
            shared.requests += 1
            shared.errors += error
            if shared.job.mode == "fixed":
                shared.latencies.append(now - self._sent_at)
        if shared.job.mode == "closed":
            self._send()
            return
        self._next += shared.period
        if self._next <= now:
            self._next = now  # late: send at once, and do not catch up afterwards
            self._send()
        else:
            shared.loop.call_at(self._next, self._send)


async def run_job(job: Job) -> Result:
    """Drive one server as ``job`` says; returns what happened inside the measuring window."""
    shared = _Shared(job)
    loop = shared.loop
    clients: list[_Client] = []
    for _ in range(job.clients):
        _, client = await loop.create_connection(lambda: _Client(shared), job.host, job.port)
        clients.append(client)
    start = loop.time()
    for index, client in enumerate(clients):
        offset = 0.0 if job.mode == "closed" else index * shared.period / job.clients
        client.start(start + offset)
    await asyncio.sleep(job.warmup)
    shared.counting = True
    cpu0, own0, t0 = process_cpu(job.pid), time.process_time(), time.perf_counter()
    await asyncio.sleep(job.seconds)
    shared.counting = False
    cpu1, own1, t1 = process_cpu(job.pid), time.process_time(), time.perf_counter()
    shared.stopped = True
    for client in clients:
        if client._transport is not None:
            client._transport.close()
    await asyncio.wait([c.lost for c in clients], timeout=5)
    return Result(
        requests=shared.requests,
        errors=shared.errors,
        dropped=shared.dropped,
        elapsed=t1 - t0,
        server_cpu=cpu1 - cpu0,
        client_cpu=own1 - own0,
        latencies=tuple(shared.latencies),
    )


def _worker(conn: Connection) -> None:
    """The client process: run every job received, answer its :class:`Result`."""
    while True:
        job = conn.recv()
        if job is None:
            return
        try:
            conn.send(asyncio.run(run_job(job)))
        except Exception as exc:  # report it to the caller instead of dying silently
            conn.send(exc)


class ClientProcess:
    """A process that runs :class:`Job` s one after the other (see :func:`client_process`)."""

    def __init__(self, conn: Connection) -> None:
        self._conn = conn

    def run(self, job: Job) -> Result:
        self._conn.send(job)
        answer = self._conn.recv()
        if isinstance(answer, Exception):
            raise answer
        assert isinstance(answer, Result)
        return answer


@contextmanager
def client_process() -> Iterator[ClientProcess]:
    """Start the client process; it stops when the ``with`` block ends."""
    context = multiprocessing.get_context("spawn")
    ours, theirs = context.Pipe()
    process = context.Process(target=_worker, args=(theirs,), daemon=True)
    process.start()
    try:
        yield ClientProcess(ours)
    finally:
        ours.send(None)
        process.join(timeout=10)
        if process.is_alive():
            process.kill()

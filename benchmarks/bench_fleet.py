"""A fleet of virtual loggers in one process (issues 11, 24): latency through the sampling
minute, CPU share, memory, start-up.

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_fleet.py [--loggers 10000] [--poll 1000] [--runs 3]``
(``--quick``: 500 loggers, 100 polled, two runs; ``--start-only [--compare BASE/src]``:
start-up alone, fresh and configured, alternating with a base tree).

1. A site file declares ``--loggers`` loggers as one numbered range (``[[loggers]]`` with
   ``count``, every port chosen free); ``sondalog serve`` runs them in one process (its
   default event loop: uvloop when installed; ``--loop asyncio`` for the standard one).
2. Through the protocol (three lines a logger), every logger gets ``--channels`` channels
   (the supply, no switch) sampling every 60 s from a whole minute, and its clock set to the
   wall clock: all loggers sample within the same second or two of every minute, the worst
   case for answering while they sample.
3. For ``--seconds`` (more than a minute: the window holds a sampling minute) a client in
   this process polls ``--poll`` of the loggers, each once a second over its own TCP
   connection, with ``read i version``, and times every answer.
4. The server is stopped and started again on its state (``--runs`` in all); every run
   measures its start-up (the first on a fresh state directory, the others on the state the
   first one left) and its window.

Prints per run and then the best and median over the runs: start-up to the last
"listening" line (goal <= 10 s), the server's CPU share of one core over the window
(``/proc/PID/stat``), its RSS at the end and peak (goal <= 500 MB for 10,000 loggers), and
the answer latency p50 / p99 / max over the window and p99 within the sampling second and
the two after it (goal p99 <= 50 ms). Per run also: the CPU seconds the server used to start
(on a machine shared with other work the wall time says less), the answers over 100 ms by
second of the minute, and this client's own lateness (a starved client measures late).

The module clocks follow the wall clock's local time (``write date``); the loggers'
minutes start with the wall clock's in any time zone whose offset is whole minutes.

``--fill ROWS`` (a long run: a month of 1-minute rows is 43,200): before the first start
every logger's memory gets ROWS record rows of 4 channels (one of 8 random walks, 1-minute
stamps, written into the fleet's database as the loggers would have, with the record's
size), so the RSS figures show what a fleet that has run for that long holds. Mind the
disk: about 50 bytes a row and logger (``--loggers 1000 --fill 24000``: 1.2 GB; the
factory record holds about 24,000 such rows).
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

HOST = "127.0.0.1"
TICK = os.sysconf("SC_CLK_TCK")
POLL = b"read i version\r"
#: The client's own lateness of its last window (set by :func:`poll`).
LAGS: list[float] = []
#: CPU seconds each server had used when its last logger listened (set by :func:`start`).
STARTS: list[float] = []


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


def start(
    count: int, work: Path, loop: str, tree: str | None = None
) -> tuple[subprocess.Popen[bytes], list[int], float]:
    """Serve ``count`` loggers on ``work/state`` (``tree``: the ``src`` directory to run)."""
    site = work / "fleet.toml"
    site.write_text(
        f'[[loggers]]\ncount = {count}\nserial_number = "F{{n:05}}"\nlisten = "{HOST}:0"\n'
    )
    env = {**os.environ, "SONDALOG_LOOP": loop}
    if tree is not None:
        env["PYTHONPATH"] = tree
    began = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(work / "state")],
        stdout=subprocess.PIPE,
        stderr=open(work / "serve.log", "ab"),  # noqa: SIM115 - closed with the process
        env=env,
    )
    assert proc.stdout is not None
    ports: list[int] = []
    watchdog = threading.Timer(600, proc.kill)  # (the lines come in bursts: no select)
    watchdog.start()
    try:
        while len(ports) < count:
            line = proc.stdout.readline().decode()
            if not line.startswith("logger "):
                proc.kill()
                sys.exit(f"serve failed: {line!r}\n{(work / 'serve.log').read_text()[-2000:]}")
            ports.append(int(line.rsplit(":", 1)[1]))
    finally:
        watchdog.cancel()
    STARTS.append(cpu_seconds(proc.pid))
    return proc, ports, time.perf_counter() - began


def prefill(count: int, work: Path, rows: int) -> None:
    """``rows`` record rows in each of ``count`` loggers' memory (see ``--fill``)."""
    import random

    from sondalog.ala1.record import RecordChanges
    from sondalog.backends.store.ala1_nv import NvDatabase

    states = work / "state" / "loggers"
    states.mkdir(parents=True, mode=0o700)
    database = NvDatabase(states / "fleet.sqlite")
    rng = random.Random(24)
    began = time.perf_counter()
    start = int(time.time()) // 60 * 60 - rows * 60
    stamps = [time.strftime("%Y%m%d%H%M%S", time.localtime(start + s * 60)) for s in range(rows)]
    variants = []  # (a few random walks, taken in turn: a fleet of thousands fills in minutes)
    for _ in range(min(count, 8)):
        values = [12.0, 11.5, 20.0, 3.3]
        made = []
        for seq in range(rows):
            values = [round(v + rng.choice((-0.01, 0.0, 0.0, 0.01)), 2) for v in values]
            made.append((seq, f"{stamps[seq]}.0,1," + ",".join(f"{v:.2f}" for v in values)))
        size = {"chars": sum(len(row) + 2 for _, row in made), "end": rows}  # (as an engine)
        if "chars" not in RecordChanges.__dataclass_fields__:
            size = {}  # (a tree before the record's size was stored: --fill compares it too)
        variants.append(RecordChanges(made, 0, False, False, **size))
    for n in range(1, count + 1):
        database.write([(f"F{n:05}", ({}, None, variants[n % len(variants)], None))])
    database.close()
    print(f"prefilled {count} x {rows} rows in {time.perf_counter() - began:.0f} s")


def stop(proc: subprocess.Popen[bytes]) -> None:
    proc.terminate()
    try:
        proc.wait(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


async def ask(port: int, lines: list[bytes], date: int | None = None) -> None:
    """Send each line, waiting for its OK; line ``date`` gets `` write date NOW`` appended
    (the wall clock's local time as it leaves)."""
    reader, writer = await asyncio.open_connection(HOST, port)
    try:
        for index, line in enumerate(lines):
            if index == date:
                line = line + time.strftime(" write date %Y%m%d%H%M%S").encode()
            writer.write(line + b"\r")
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
    """Three lines a logger (channel lists, §6.5.2): output 1 powers the supply divider
    (§6.7.3) for good, so no channel switches it. Each clock is set to the wall clock's
    second as the line leaves (§6.2): its minutes start within a second after the wall
    clock's, so every logger samples in the first second or two of every minute."""
    each = " ".join(["1"] * channels)
    lines = [
        f"write channel max number {channels} write output 1 value 1 "
        f"write channel type {each} write channel switch output {each.replace('1', '0')}".encode(),
        f"write channel sampling period {' '.join(['000100'] * channels)}".encode(),
        f"write channel sampling start {' '.join(['20000101000000'] * channels)}".encode(),
    ]
    gate = asyncio.Semaphore(50)

    async def one(port: int) -> None:
        async with gate:
            await ask(port, lines, date=1)

    await asyncio.gather(*(one(port) for port in ports))


class _Poller(asyncio.Protocol):
    """One connection: ``read i version`` once a second, each answer timed."""

    def __init__(self, answers: list[tuple[float, float]]) -> None:
        self.answers = answers
        self.transport: asyncio.Transport | None = None
        self.buffer = b""
        self.sent = 0.0
        self.wall = 0.0

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]

    def send(self) -> None:
        assert self.transport is not None
        self.sent, self.wall = time.perf_counter(), time.time()
        self.transport.write(POLL)

    def data_received(self, data: bytes) -> None:
        self.buffer += data
        if self.buffer.endswith(b"OK\r\n"):
            self.answers.append((self.wall, time.perf_counter() - self.sent))
            self.buffer = b""


async def poll(ports: list[int], seconds: float) -> list[tuple[float, float]]:
    """(wall time sent, latency) of every answer; each port polled once a second."""
    loop = asyncio.get_running_loop()
    answers: list[tuple[float, float]] = []
    pollers = []
    for port in ports:
        _, protocol = await loop.create_connection(lambda: _Poller(answers), HOST, port)
        pollers.append(protocol)
    step = 1.0 / max(1, len(pollers))
    began = loop.time() + 0.5
    ticks = int(seconds)
    for tick in range(ticks):
        for i, poller in enumerate(pollers):
            loop.call_at(began + tick + i * step, poller.send)
    lags: list[float] = []  # how late this process's own 10 ms ticks ran (its starvation)
    tick_at = loop.time()
    while tick_at < began + ticks + 1.0:
        tick_at += 0.01
        await asyncio.sleep(tick_at - loop.time())
        lags.append(loop.time() - tick_at)
    LAGS[:] = lags
    for poller in pollers:
        assert poller.transport is not None
        poller.transport.close()
    return answers


@dataclass
class Run:
    start: float
    cpu: float
    rss: float
    peak: float
    p50: float
    p99: float
    worst: float
    p99_sampling: float
    answers: int
    expected: int


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[max(0, int(len(ordered) * share) - 1)] if ordered else float("nan")


def measure(proc: subprocess.Popen[bytes], ports: list[int], args: argparse.Namespace) -> Run:
    cpu0, t0 = cpu_seconds(proc.pid), time.perf_counter()
    answers = asyncio.run(poll(ports[: args.poll], args.seconds))
    cpu1, t1 = cpu_seconds(proc.pid), time.perf_counter()
    rss, peak = memory_mb(proc.pid)
    latencies = [latency * 1000 for _, latency in answers]
    # every logger samples in the first second or two of a wall-clock minute (configure)
    sampling = [latency * 1000 for wall, latency in answers if int(wall) % 60 < 3]
    slow: dict[int, int] = {}
    for wall, latency in answers:
        if latency > 0.1:
            slow[int(wall) % 60] = slow.get(int(wall) % 60, 0) + 1
    print(f"  answers over 100 ms by second of the minute: {dict(sorted(slow.items()))}")
    print(
        f"  the client's own lateness: max {max(LAGS) * 1000:.0f} ms, "
        f"{sum(lag > 0.05 for lag in LAGS)} ticks over 50 ms"
    )
    return Run(
        start=0.0,
        cpu=(cpu1 - cpu0) / (t1 - t0) * 100,
        rss=rss,
        peak=peak,
        p50=percentile(latencies, 0.5),
        p99=percentile(latencies, 0.99),
        worst=max(latencies, default=float("nan")),
        p99_sampling=percentile(sampling, 0.99),
        answers=len(answers),
        expected=int(args.seconds) * min(args.poll, len(ports)),
    )


def start_only(args: argparse.Namespace) -> None:
    """``--start-only``: start-up alone, on a fresh state and on a configured one that has
    sampled once, ``--runs`` times each; with ``--compare SRC`` the starts alternate
    between this tree and SRC (a base tree), minute by minute under the same load."""
    here = str(Path(__file__).resolve().parent.parent / "src")
    trees = [here] + ([args.compare] if args.compare else [])
    figures: dict[tuple[str, str], list[tuple[float, float]]] = {}

    def one(kind: str, tree: str, work: Path) -> None:
        work.mkdir(exist_ok=True)
        proc, _, started = start(args.loggers, work, args.loop, tree)
        stop(proc)
        load = os.getloadavg()[0]
        figures.setdefault((kind, tree), []).append((started, STARTS[-1]))
        print(f"{kind} {tree}: {started:.1f} s ({STARTS[-1]:.1f} s of CPU), load {load:.2f}")

    with tempfile.TemporaryDirectory() as tmp:
        for number in range(args.runs):
            for tree in trees:
                one("fresh", tree, Path(tmp) / f"fresh{number}{len(STARTS)}")
        work = Path(tmp) / "configured"
        work.mkdir()
        proc, ports, _ = start(args.loggers, work, args.loop, trees[-1])
        try:
            asyncio.run(configure(ports, args.channels))
            time.sleep(63 - time.time() % 60)  # every logger samples once
        finally:
            stop(proc)
        for _ in range(args.runs):
            for tree in trees:
                one("existing", tree, work)
    print(f"\n{args.loggers} loggers, start-up to the last listening line: best / median of "
          f"{args.runs} (s), CPU the server used to start (s)")  # fmt: skip
    print("| state | tree | start best | start median | CPU best | CPU median |")
    print("|---|---|---|---|---|---|")
    for (kind, tree), runs in figures.items():
        walls, cpus = [w for w, _ in runs], [c for _, c in runs]
        print(
            f"| {kind} | {tree} | {min(walls):.1f} | {statistics.median(walls):.1f} | "
            f"{min(cpus):.1f} | {statistics.median(cpus):.1f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loggers", type=int, default=10_000)
    parser.add_argument("--channels", type=int, default=4)
    parser.add_argument("--poll", type=int, default=1000, help="loggers polled once a second")
    parser.add_argument("--seconds", type=float, default=75.0, help="measuring window")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--loop", choices=("auto", "asyncio", "uvloop"), default="auto")
    parser.add_argument("--quick", action="store_true", help="500 loggers, 100 polled, 2 runs")
    parser.add_argument("--fill", type=int, default=0, help="record rows per logger at start")
    parser.add_argument("--start-only", action="store_true", help="start-up figures alone")
    parser.add_argument("--compare", help="with --start-only: a base tree's src to alternate")
    args = parser.parse_args()
    if args.start_only:
        start_only(args)
        return
    if args.quick:
        args.loggers, args.poll, args.runs = 500, 100, 2
    load = os.getloadavg()[0]
    print(f"{os.cpu_count()} CPUs, load average {load:.2f}; python {sys.version.split()[0]}")
    runs: list[Run] = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if args.fill:
            prefill(args.loggers, work, args.fill)
        for number in range(args.runs):
            proc, ports, started = start(args.loggers, work, args.loop)
            if number == 0 and args.fill:
                rss, _ = memory_mb(proc.pid)
                print(f"RSS after start with {args.fill} rows a logger: {rss:.0f} MB")
            try:
                if number == 0:
                    maps = Path(f"/proc/{proc.pid}/maps").read_text()
                    loop = "uvloop" if "/uvloop/" in maps else "asyncio"
                    began = time.perf_counter()
                    asyncio.run(configure(ports, args.channels))
                    print(f"setup through the protocol: {time.perf_counter() - began:.0f} s")
                run = measure(proc, ports, args)
                run.start = started
                status = asyncio.run(record_status(ports[-1]))
            finally:
                stop(proc)
            runs.append(run)
            print(
                f"run {number + 1}: start {run.start:.1f} s ({STARTS[-1]:.1f} s of CPU), "
                f"CPU {run.cpu:.1f} %, RSS "
                f"{run.rss:.0f} / peak {run.peak:.0f} MB, latency p50 {run.p50:.2f} / p99 "
                f"{run.p99:.1f} / max {run.worst:.0f} ms, p99 in the sampling seconds "
                f"{run.p99_sampling:.1f} ms, {run.answers}/{run.expected} answers; "
                f"last logger's record status {status}",
                flush=True,
            )
    print(
        f"\n{args.loggers} loggers x {args.channels} channels every 60 s, all sampling in the "
        f"same second, one process ({loop}); {args.poll} polled once a second for "
        f"{args.seconds:.0f} s; {args.runs} runs"
    )
    print("| figure | best | median | goal |")
    print("|---|---|---|---|")

    def row(name: str, values: list[float], goal: str, fmt: str = ".1f") -> None:
        best = min(values)
        print(f"| {name} | {best:{fmt}} | {statistics.median(values):{fmt}} | {goal} |")

    row("start-up to the last listening line (s)", [r.start for r in runs], "<= 10 s")
    row("CPU the server used to start (s)", STARTS, "")
    row("server CPU, share of one core (%)", [r.cpu for r in runs], "")
    row("RSS at the end (MB)", [r.rss for r in runs], "<= 500 MB", ".0f")
    row("peak RSS (MB)", [r.peak for r in runs], "", ".0f")
    row("latency p50 (ms)", [r.p50 for r in runs], "", ".2f")
    row("latency p99 over the window (ms)", [r.p99 for r in runs], "<= 50 ms")
    row("latency p99, sampling second + 2 s (ms)", [r.p99_sampling for r in runs], "<= 50 ms")
    row("latency max (ms)", [r.worst for r in runs], "", ".0f")
    row("answers / expected", [r.answers / r.expected for r in runs], "1", ".3f")


if __name__ == "__main__":
    main()

"""Benchmark: the collector's cost per contact against a fleet of virtual loggers (issue 24).

A fleet of ``--loggers`` virtual loggers (``sondalog serve`` with one ``[[loggers]]`` range,
its own process) samples ``--channels`` channels every 60 s. ``sondalog collect`` (another
process, dashboard off) has one logger source per logger, each contacted every
``--interval`` seconds. After a warm-up (the first contacts download each record from the
start) a window of ``--seconds`` measures:

- the collector's CPU share of one core and its CPU per contact (``/proc/PID/task/*/schedstat``);
- its RSS at the end and its peak (``VmHWM``);
- contacts and errors in the window (the store's events);
- starvation: every 10 s, for every source, how far its newest stored row (the cursor kept
  with the readings) is behind the logger's clock; the worst over the window. Goal: at most
  two intervals plus one sampling period.

Each source reads its logger's configuration every ``--config-every`` contacts (issue 22,
``config_every``; default 0, never): reading the 841 settings of a 2.10 logger is 191 answers,
about ten times a contact's own work for both ends, which ``bench_config_watch.py`` measures;
for ten thousand sources docs/collector.md advises ``config_every = 0`` or a large N.

``--keep-open`` measures this tree (and ``--compare``'s) twice a run: its default path (a
connection a contact) and with ``keep_open = true`` on every source (the connection kept
between contacts, docs/collector.md), side by side in the table; the sondalog fleet's
servers take several connections, as keep_open needs. A kept connection is a file on both
sides: a logger process then holds two a logger (its listener and the connection), so the
fleet is split over ``--fleets`` processes (default: as many as the open-file limit needs)
for every path alike. ``--profile DIR`` runs each collector under cProfile (its figures then
carry the profiler's overhead).

``--compare OLD_SRC`` runs the same measurement with the collector's code from another tree
(``git archive BASE src | tar -x -C /tmp/base``), interleaved with this tree's runs against
the same fleet, so that before and after meet the same machine load.

    .venv/bin/python benchmarks/bench_collect_fleet.py --loggers 10000 --interval 60
    .venv/bin/python benchmarks/bench_collect_fleet.py --loggers 1000 --interval 5 --seconds 60
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import os
import random
import resource
import select
import signal
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fleet import configure  # the fleet's setup through the protocol
from loadgen import process_cpu

HERE = Path(__file__).resolve().parent.parent / "src"
SAMPLING = 60.0  # the fleet's sampling period (bench_fleet.configure: 000100)


@dataclass
class Run:
    label: str
    cpu: float
    seconds: float
    contacts: int
    errors: int
    rss: float
    peak: float
    worst_lag: float
    never: int  # sources with no stored row at the end

    @property
    def share(self) -> float:
        return self.cpu / self.seconds

    @property
    def ms_per_contact(self) -> float:
        return self.cpu / max(self.contacts, 1) * 1000


def start(count: int, work: Path) -> tuple[subprocess.Popen[bytes], list[int], float]:
    """``sondalog serve`` with one ``[[loggers]]`` range on consecutive ports from a random
    free-looking base (port 0 for 10,000 listeners at once is not reliable); another base
    when a port of the range is taken (another fleet on the machine)."""
    for _ in range(5):
        started = _start(count, work)
        if started is not None:
            return started
    sys.exit(f"serve failed five times:\n{(work / 'serve.log').read_text()[-2000:]}")


def _listening() -> set[int]:
    """The TCP ports something listens on (``/proc/net/tcp``, state 0A)."""
    ports = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with contextlib.suppress(OSError):
            for line in Path(table).read_text().splitlines()[1:]:
                fields = line.split()
                if fields[3] == "0A":
                    ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


def _start(count: int, work: Path) -> tuple[subprocess.Popen[bytes], list[int], float] | None:
    low, _ = map(int, Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split())
    taken = _listening()
    bases = [
        b
        for b in range(10_000, max(10_001, low - count), 500)
        if not any(b <= p < b + count for p in taken)
    ]  # below the ephemeral ports, clear of other listeners (another fleet)
    base = random.choice(bases) if bases else random.randrange(10_000, max(10_001, low - count))
    site = work / "fleet.toml"
    site.write_text(
        f'[[loggers]]\ncount = {count}\nserial_number = "F{{n:05}}"\nlisten = "127.0.0.1:{base}"\n'
    )
    began = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(work / "state")],
        stdout=subprocess.PIPE,
        stderr=open(work / "serve.log", "wb"),  # noqa: SIM115 - closed with the process
    )
    assert proc.stdout is not None
    ports: list[int] = []
    while len(ports) < count:
        ready, _, _ = select.select([proc.stdout], [], [], 180)
        line = proc.stdout.readline().decode() if ready else ""
        if not line.startswith("logger "):
            proc.kill()
            proc.wait()
            if "address already in use" in (work / "serve.log").read_text():
                return None
            sys.exit(f"serve failed: {line!r}\n{(work / 'serve.log').read_text()[-2000:]}")
        ports.append(int(line.rsplit(":", 1)[1]))
    return proc, ports, time.perf_counter() - began


def memory_mb(pid: int) -> tuple[float, float]:
    values = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, rest = line.partition(":")
        if key in ("VmRSS", "VmHWM"):
            values[key] = int(rest.split()[0]) / 1024
    return values["VmRSS"], values["VmHWM"]


async def logger_offset(port: int) -> float:
    """Seconds the fleet's clock is ahead of this host's local time."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(b"read date\r")
    answer = await reader.readuntil(b"OK\r\n")
    writer.close()
    logger = datetime.strptime(answer.split()[0].decode(), "%Y%m%d%H%M%S")
    return (logger - datetime.now()).total_seconds()


def counts(db: sqlite3.Connection) -> tuple[int, int]:
    row = db.execute(
        "SELECT sum(kind = 'download'), sum(kind = 'error') FROM events WHERE id > 0"
    ).fetchone()
    return int(row[0] or 0), int(row[1] or 0)


def lags(db: sqlite3.Connection, offset: float) -> tuple[float, int]:
    """The worst source's lag (seconds behind the logger's clock) and sources never stored."""
    now = time.time() + offset
    worst, never = 0.0, 0
    for (cursor,) in db.execute("SELECT cursor FROM sources"):
        if cursor is None:
            never += 1
            continue
        stamp = datetime.strptime(cursor[:14], "%Y%m%d%H%M%S").timestamp()
        worst = max(worst, now - stamp)
    return worst, never


def config_text(ports: list[int], interval: float, config_every: int, keep_open: bool) -> str:
    """The collector's file: a source a logger port, the store beside it, no dashboard."""
    return (
        '[sqlite]\npath = "store.sqlite"\n[web]\nenabled = false\n'
        # the [collect] default: a key a source would not fit 10,000 in the 1 MiB
        + ("[collect]\nkeep_open = true\n" if keep_open else "")
        + "".join(
            # compact (retry = 5 is the default): 10,000 sources within the 1 MiB a
            # configuration file may have
            f'\n[[source]]\nname="s{i:05d}"\nurl="tcp://127.0.0.1:{port}"\n'
            f"interval={interval:g}\nretry_max=30\nconfig_every={config_every}\n"
            for i, port in enumerate(ports)
        )
    )


def measure(
    label: str,
    src: Path,
    ports: list[int],
    args: argparse.Namespace,
    offset: float,
    keep_open: bool = False,
) -> Run:
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "collector.toml"
        config.write_text(config_text(ports, args.interval, args.config_every, keep_open))
        env = {**os.environ, "PYTHONPATH": str(src)}
        profile: list[str] = []
        if args.profile is not None:  # the whole run, warm-up included (cProfile's overhead)
            args.profile.mkdir(parents=True, exist_ok=True)
            name = (
                label.replace(" ", "_").replace(",", "") + f"-{len(list(args.profile.iterdir()))}"
            )
            profile = ["-m", "cProfile", "-o", str(args.profile / f"{name}.prof")]
        proc = subprocess.Popen(
            [sys.executable, *profile, "-m", "sondalog", "collect", str(config)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            time.sleep(args.warmup)
            db = sqlite3.connect(f"file:{tmp}/store.sqlite?mode=ro", uri=True, timeout=30)
            c0, e0 = counts(db)
            cpu0, t0 = process_cpu(proc.pid), time.perf_counter()
            worst = 0.0
            while time.perf_counter() - t0 < args.seconds:
                time.sleep(min(10.0, max(0.0, args.seconds - (time.perf_counter() - t0))))
                worst = max(worst, lags(db, offset)[0])
            cpu1, t1 = process_cpu(proc.pid), time.perf_counter()
            rss, peak = memory_mb(proc.pid)
            c1, e1 = counts(db)
            never = lags(db, offset)[1]
            if e1 > e0:  # what went wrong, most often
                text = db.execute(
                    "SELECT text, count(*) AS n FROM events WHERE kind = 'error' "
                    "GROUP BY substr(text, 1, 40) ORDER BY n DESC LIMIT 1"
                ).fetchone()
                print(f"  {label}: errors, most often ({text[1]}): {text[0]}", flush=True)
            db.close()
        finally:
            proc.send_signal(signal.SIGTERM)
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=60)
            if proc.poll() is None:
                proc.kill()
    return Run(label, cpu1 - cpu0, t1 - t0, c1 - c0, e1 - e0, rss, peak, worst, never)


def summary(runs: list[Run], args: argparse.Namespace) -> bool:
    """The table of the runs; False when a run starved a source (its newest stored reading
    more than two intervals plus one sampling period behind, or none stored)."""
    limit = 2 * args.interval + SAMPLING
    print(
        "| tree | CPU share (best / median) | ms CPU a contact | contacts/s | RSS / peak MB "
        f"| worst lag s (goal <= {limit:g}) | errors |"
    )
    print("|---|---|---|---|---|---|---|")
    for label in dict.fromkeys(r.label for r in runs):
        mine = [r for r in runs if r.label == label]
        share = sorted(r.share * 100 for r in mine)
        per = sorted(r.ms_per_contact for r in mine)
        rate = statistics.median(r.contacts / r.seconds for r in mine)
        print(
            f"| {label} | {share[0]:.1f} / {statistics.median(share):.1f} % "
            f"| {per[0]:.2f} / {statistics.median(per):.2f} | {rate:.1f} "
            f"| {max(r.rss for r in mine):.0f} / {max(r.peak for r in mine):.0f} "
            f"| {max(r.worst_lag for r in mine):.0f} (never stored: {max(r.never for r in mine)}) "
            f"| {sum(r.errors for r in mine)} |"
        )
    starved = [r for r in runs if r.worst_lag > limit or r.never]
    for r in starved:
        print(
            f"STARVED: {r.label}: worst lag {r.worst_lag:.0f} s > {limit:g} s "
            f"or {r.never} sources never stored"
        )
    if not starved:
        print(f"none starved: every run's worst lag is at most {limit:g} s")
    return not starved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loggers", type=int, default=10_000)
    parser.add_argument("--channels", type=int, default=4)
    parser.add_argument("--interval", type=float, default=60.0)
    parser.add_argument("--seconds", type=float, default=120.0, help="measuring window")
    parser.add_argument("--warmup", type=float, default=None, help="default: interval + 20 s")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--compare", type=Path, help="another tree's src/ (before)")
    parser.add_argument(
        "--keep-open",
        action="store_true",
        help="also measure this tree (and --compare's) with keep_open = true on every source "
        "(both paths reported)",
    )
    parser.add_argument(
        "--config-every", type=int, default=0, help="config_every of each source (0: never)"
    )
    parser.add_argument(
        "--fleets", type=int, default=None, help="serve processes (default: what files allow)"
    )
    parser.add_argument(
        "--profile",
        type=Path,
        default=None,
        help="run every collector under cProfile, its stats in this directory (LABEL-N.prof; "
        "the figures then include the profiler's overhead)",
    )
    args = parser.parse_args()
    if args.fleets is None:  # a kept connection is a second file a logger in its process
        files = resource.getrlimit(resource.RLIMIT_NOFILE)[0] - 500
        per = files // 2 if args.keep_open else files
        args.fleets = max(1, -(-args.loggers // per))
    if args.warmup is None:
        args.warmup = args.interval + 20
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    trees = [("this tree", HERE, False)]
    if args.keep_open:
        trees.append(("this tree, keep_open", HERE, True))
    if args.compare:
        trees.append(("compare", args.compare, False))
        if args.keep_open:  # the other tree's kept connections too, in the same minutes
            trees.append(("compare, keep_open", args.compare, True))
    with tempfile.TemporaryDirectory() as tmp:
        fleets, ports, started = [], [], 0.0
        for n in range(args.fleets):
            count = args.loggers // args.fleets + (n < args.loggers % args.fleets)
            work = Path(tmp) / f"fleet{n}"
            work.mkdir()
            fleet, more, took = start(count, work)
            fleets.append(fleet)
            ports += more
            started += took
        try:
            asyncio.run(configure(ports, args.channels))
            offset = asyncio.run(logger_offset(ports[0]))
            # every logger holds rows before the first collector starts: past the next minute
            time.sleep(62 - (time.time() + offset) % 60)
            print(
                f"fleet of {args.loggers} loggers x {args.channels} channels every 60 s "
                f"(started in {started:.0f} s); {args.loggers} sources every {args.interval:g} s, "
                f"window {args.seconds:g} s after {args.warmup:g} s, "
                f"config_every = {args.config_every}"
            )
            runs: list[Run] = []
            for index in range(args.runs):
                for label, src, keep in trees if index % 2 == 0 else trees[::-1]:
                    run = measure(label, src, ports, args, offset, keep)
                    print(
                        f"  {label}: {run.share:.1%} of a core, {run.ms_per_contact:.2f} ms a "
                        f"contact, {run.contacts} contacts, RSS {run.rss:.0f} MB, "
                        f"worst lag {run.worst_lag:.0f} s, errors {run.errors}",
                        flush=True,
                    )
                    runs.append(run)
        finally:
            for fleet in fleets:
                fleet.terminate()
            for fleet in fleets:
                fleet.wait(timeout=60)
    if not summary(runs, args):
        sys.exit(1)


if __name__ == "__main__":
    main()

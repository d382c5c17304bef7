"""Benchmark: readings ingested per second by the collector's sinks (goal >= 50,000/s;
PostgreSQL >= 250,000/s, issue 24).

PostgreSQL: starts a throwaway server (Debian's ``postgresql``, as ``nobody`` on a loopback
port, like the tests) and writes batches through :class:`~sondalog.collect.sink_postgres.
PostgresSink` (schema version 2: the readings grouped into record rows, binary COPY, a batch
split between ``--writers`` connections; a batch with stored rows through a temporary table,
``INSERT ... ON CONFLICT DO NOTHING`` and the merge of missing channels; the per-block
extremes of the dashboard kept in the same transaction, those the sink knows would not
change left out): first new rows, then the same rows again (all duplicates, the cost of an
idempotent replay). The readings: 20 loggers, rows of 8 channels a minute apart, each
channel's values repeating every 5 rows (a 5,000-reading batch touches about 850 blocks of
the 4 sizes, about 260 of them new or changed). ``--runs``
fresh databases; best and median. Besides the rate it prints the CPU a reading costs this
process (formatting, sending) and the server's backends (``/proc``; the server runs here):
on a shared machine those move less than the rate does.

MQTT: the same readings, a tenth of them, as QoS 1 state messages to a local mosquitto
(for information; the issue sets no goal for it).

SQLite: the collector's own store, when its sink module (``sondalog.collect.sink_sqlite``,
``create({"path": ...})``) is present; skipped with a note otherwise.

Not a test: it prints figures.

    .venv/bin/python benchmarks/bench_collect.py [--readings 500000] [--batch 5000] [--runs 3]
        [--only postgres] [--writers 1]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import functools
import gc
import importlib
import os
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from datetime import datetime, timedelta
from pathlib import Path

from sondalog.collect.model import Reading, Sink

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "collect"))
import services  # the tests' real-server helpers


def make_batches(
    total: int, batch: int, loggers: int = 20, channels: int = 8
) -> list[list[Reading]]:
    """``total`` readings from ``loggers`` loggers, rows of ``channels`` channels each."""
    t0 = datetime(2026, 1, 1)
    out: list[Reading] = []
    row = 0
    while len(out) < total:
        lg = f"{10000 + row % loggers}"
        t = t0 + timedelta(seconds=60 * (row // loggers))
        for ch in range(1, channels + 1):
            out.append(Reading(lg, ch, t, 0, 1, 20.0 + ch + (row % 100) / 10, None, f"T{ch}", "°C"))
        row += 1
    out = out[:total]
    return [out[i : i + batch] for i in range(0, total, batch)]


async def ingest(sink: Sink, batches: list[list[Reading]]) -> float:
    start = time.perf_counter()
    for b in batches:
        await sink.write(b)
    return time.perf_counter() - start


def report(label: str, n: int, seconds: list[float], goal: int = 50_000) -> None:
    rates = sorted((n / s for s in seconds), reverse=True)
    verdict = "ok" if rates[0] >= goal else "BELOW GOAL"
    print(
        f"{label:<42} {n:>9,} readings: best {rates[0]:>9,.0f}/s, median "
        f"{statistics.median(rates):>9,.0f}/s of {len(rates)}  ({verdict}, goal {goal:,})"
    )


async def bench_sink(
    label: str,
    sinks: list[Sink],
    batches: list[list[Reading]],
    goal: int = 50_000,
    server_cpu: Sequence[Callable[[], float]] = (),
) -> None:
    """Each sink (a fresh store each) takes the batches as new rows, then again.

    ``server_cpu[i]``: the CPU seconds the server has spent on ``sinks[i]`` so far."""
    n = sum(len(b) for b in batches)
    new, again = [], []
    cpu: dict[str, list[tuple[float, float]]] = {"new": [], "again": []}
    for i, sink in enumerate(sinks):
        await sink.open()
        spent = server_cpu[i] if server_cpu else float
        for phase, times in (("new", new), ("again", again)):
            c0, s0 = time.process_time(), spent()
            times.append(await ingest(sink, batches))
            c1, s1 = time.process_time(), spent()
            cpu[phase].append((c1 - c0, s1 - s0))
        await sink.close()
    report(f"{label}: new rows", n, new, goal)
    report(f"{label}: same rows again (duplicates)", n, again, goal)
    if server_cpu:
        for phase, used in cpu.items():
            client = statistics.median(c for c, _ in used) / n * 1e6
            server = statistics.median(s for _, s in used) / n * 1e6
            print(
                f"  CPU a reading ({phase}, median): this process {client:.2f} us,"
                f" server {server:.2f} us"
            )


def backends_cpu(dsn: str) -> float:
    """CPU seconds (user + system) of the server's backends on ``dsn``'s database, from
    ``/proc`` (the server runs on this machine); this query's own backend left out."""
    import psycopg

    with psycopg.connect(dsn, autocommit=True) as c:
        pids = c.execute(
            "SELECT pid FROM pg_stat_activity"
            " WHERE datname = current_database() AND pid <> pg_backend_pid()"
        ).fetchall()
    total = 0.0
    for (pid,) in pids:
        with contextlib.suppress(OSError):
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


async def bench_postgres(dsns: list[str], writers: int, batches: list[list[Reading]]) -> None:
    """A sink on each database (a fresh one each run), the CPU of its backends read too."""
    from sondalog.collect import sink_postgres

    sinks: list[Sink] = [sink_postgres.create({"dsn": d, "writers": writers}) for d in dsns]
    cpu = [functools.partial(backends_cpu, d) for d in dsns]
    await bench_sink("PostgreSQL", sinks, batches, goal=250_000, server_cpu=cpu)


async def bench_mqtt(sink: Sink, batches: list[list[Reading]]) -> None:
    """States published with QoS 1 (each acknowledged by the broker); no goal is set."""
    n = sum(len(b) for b in batches)
    await sink.open()
    seconds = await ingest(sink, batches)
    print(
        f"{'MQTT: states published (QoS 1)':<42} {n:>9,} readings in {seconds:6.2f} s"
        f" = {n / seconds:>10,.0f}/s"
    )
    await sink.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--readings", type=int, default=500_000)
    ap.add_argument("--batch", type=int, default=5_000)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--only", choices=("postgres", "mqtt", "sqlite"))
    ap.add_argument("--writers", type=int, default=1, help="PostgreSQL writer connections")
    ap.add_argument(
        "--gc",
        choices=("collector", "default"),
        default="collector",
        help="the garbage collector as `sondalog collect` sets it (default) or Python's own",
    )
    args = ap.parse_args()
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    if args.gc == "collector":  # before the batches: they are young objects, as a contact's
        from sondalog.collect import runner

        if hasattr(runner, "settle_gc"):
            runner.settle_gc()
        else:  # a tree from before settle_gc (--compare runs): what its runner did inline
            gc.freeze()
            gc.set_threshold(max(runner.GC_YOUNG, gc.get_threshold()[0]), *gc.get_threshold()[1:])
        print(f"garbage collector as the collector runs it: thresholds {gc.get_threshold()}")
    batches = make_batches(args.readings, args.batch)
    print(f"{args.readings:,} readings in batches of {args.batch:,}")

    bindir = services._pg_bin()
    if args.only not in (None, "postgres"):
        pass
    elif bindir is None:
        print("PostgreSQL: not installed; skipped")
    else:
        server = services.PostgresServer(bindir)
        try:
            server.start()
            dsns = [server.create_db() for _ in range(args.runs)]
            print(f"PostgreSQL: {args.writers} writer connections")
            asyncio.run(bench_postgres(dsns, args.writers, batches))
        finally:
            server.destroy()

    mqtt_bin = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
    if args.only not in (None, "mqtt"):
        pass
    elif not Path(mqtt_bin).exists():
        print("MQTT: mosquitto not installed; skipped")
    else:
        from sondalog.collect import sink_mqtt

        broker = services.Mosquitto(mqtt_bin)
        try:
            broker.start()
            mqtt_batches = batches[: max(1, len(batches) // 10)]  # QoS 1 is slower: a tenth
            asyncio.run(bench_mqtt(sink_mqtt.create({"url": broker.url}), mqtt_batches))
        finally:
            broker.destroy()

    if args.only not in (None, "sqlite"):
        return
    try:
        sqlite_mod = importlib.import_module("sondalog.collect.sink_sqlite")
    except ImportError:
        print("SQLite: sondalog.collect.sink_sqlite is not there yet; skipped")
        return
    with tempfile.TemporaryDirectory() as d:
        sinks = [
            sqlite_mod.create({"path": str(Path(d) / f"{i}.sqlite")}) for i in range(args.runs)
        ]
        asyncio.run(bench_sink("SQLite", sinks, batches))


if __name__ == "__main__":
    main()

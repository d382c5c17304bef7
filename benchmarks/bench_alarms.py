"""Benchmark: the cost of alarm rules at ingest (issue 21: at most 10 % of the ingest rate).

1,000 loggers x 12 channels, 10 rules that apply to every logger (thresholds above and
below with hysteresis, stuck, step, on named and numbered channels, globs on the logger),
fed the readings of downloads: one row of 12 channels per logger per minute, ``--minutes``
rows of each logger a download; three downloads one after the other: the first one ever
(each (logger, channel) has its rules matched and compiled, and every alarm's row is
created in the store), the next one (what a running collector does every time), and one
after a restart (the alarms come back from the store; the rules are compiled again).

Figures over the same readings, in download-sized chunks (one per logger):

- ``ingest``: the collector's host path after the line: record rows parsed
  (:func:`parse_row`), turned into readings (:func:`rows_to_readings`) and committed with
  the source's cursor (:meth:`SqliteStore.commit_chunk`), as ``bench_ingest_sqlite.py``;
- ``alarms``: the same readings through the alarm core, :meth:`Alarms.ingest` (the
  collector's readings evaluated straight against every rule), then the transitions
  recorded, the notifications queued and the changed states saved
  (:meth:`AlarmStore.save_changes`) in the alarm store, one transaction per chunk (the
  readings cross their limits now and then, so alarms are raised and cleared throughout);
- ``samples``: the same through the reference path, each reading made a
  :class:`~sondalog.collect.alarms.Sample` for :meth:`Alarms.readings` and the states saved
  whole (:meth:`AlarmStore.save_states`): what the first version did.

Before each timed section the objects alive are frozen out of the cyclic garbage collector
(:func:`settle_heap`; ``--gc-all`` does not): the benchmark holds three downloads of readings,
which a collector never does, and every collection the alarm path's allocations trigger
would otherwise walk them.

The ratio alarms : ingest is the goal's figure (<= 0.10), on the collector's path
(``collector``) for the next download and after a restart. Each figure is the best of
``--repeat`` runs, the median in brackets (the machine may be shared). The collector's
restart itself (its alarms loaded back from the store, before the download) is shown apart
(``restart: states loaded``). ``--paths collector`` leaves out the core's own paths.

Run: ``.venv/bin/python benchmarks/bench_alarms.py [--loggers 1000] [--minutes 10]
[--repeat 5] [--paths collector,alarms,samples]``.
"""

from __future__ import annotations

import argparse
import gc
import os
import statistics
import tempfile
import time
from dataclasses import replace
from datetime import UTC, datetime, timedelta
from pathlib import Path

from sondalog.client.records import parse_row
from sondalog.collect.alarm_loop import AlarmLoop
from sondalog.collect.alarms import AlarmPlan, Alarms, AlarmStore, Policy, Sample, parse_alarms
from sondalog.collect.config import load_config
from sondalog.collect.model import Reading
from sondalog.collect.readings import rows_to_readings
from sondalog.collect.store_sqlite import SqliteStore
from sondalog.config import loads

T0 = datetime(2026, 1, 1)

RULES = """
[[notify]]
name = "ops"
kind = "log"

[[alarm]]
kind = "threshold"
logger = "F*"
channel = 1
above = 24.5
clear = 24
notify = ["ops"]

[[alarm]]
kind = "threshold"
logger = "F*"
channel = 2
below = 0.2
clear = 0.3
for = 3
notify = ["ops"]

[[alarm]]
kind = "threshold"
logger = "F*"
channel = "T3"
above = 2.4
notify = ["ops"]

[[alarm]]
kind = "threshold"
channel = "T4"
below = 0.05
notify = ["ops"]

[[alarm]]
kind = "stuck"
logger = "F*"
channel = 5
for = 10
notify = ["ops"]

[[alarm]]
kind = "stuck"
channel = "T6"
for = 20
tolerance = 0.001
notify = ["ops"]

[[alarm]]
kind = "step"
logger = "F*"
channel = 7
step = 1.5
notify = ["ops"]

[[alarm]]
kind = "step"
channel = "T8"
step = 2
for = 3
notify = ["ops"]

[[alarm]]
kind = "threshold"
logger = "F0*"
channel = "T*"
above = 2.49
notify = ["ops"]

[[alarm]]
kind = "threshold"
channel = 12
above = 2.2
clear = 2.0
for = 2
notify = ["ops"]
"""


def rows(loggers: int, minutes: int, first: int = 0) -> dict[str, list[str]]:
    """Each logger's record rows from minute ``first``: 12 channels a row, one a minute."""
    out: dict[str, list[str]] = {}
    for n in range(loggers):
        lines = []
        for i in range(first, first + minutes):
            stamp = (T0 + timedelta(seconds=60 * i)).strftime("%Y%m%d%H%M%S")
            fields = ",".join(f"{(i * 7 + ch * 13 + n) % 2500 / 1000:.3f}" for ch in range(12))
            lines.append(f"{stamp}.0,1,{fields}")
        out[f"F{n:04}"] = lines
    return out


Chunks = list[tuple[str, list[Reading]]]
#: Whether the objects alive before a timed section are left out of the garbage collector's
#: passes during it (``--gc-all`` keeps them in).
FREEZE = True


def settle_heap() -> None:
    """Before a timed section: the benchmark's own data (three downloads of readings, some
    360,000 objects, which no collector holds) out of the cyclic garbage collector's passes
    (``gc.freeze``), so a section pays for the passes its own allocations cause, not for
    walking the benchmark's memory. The same for every path."""
    if FREEZE:
        gc.collect()
        gc.freeze()


NAMES = {ch: f"T{ch}" for ch in range(1, 13)}
#: The process's CPU seconds of each timed section of the ingest and the collector paths, in
#: order: on a shared machine, what a path costs whatever else runs (wall time also waits).
CPU: dict[str, list[float]] = {}


def ingest(store: SqliteStore, per_logger: dict[str, list[str]]) -> tuple[float, Chunks]:
    """The ingest path's time for one download of every logger, and its readings."""
    chunks: Chunks = []
    settle_heap()
    started, cpu = time.perf_counter(), time.process_time()
    for logger, lines in per_logger.items():
        store.add_source(logger, f"tcp://x:{logger}", "logger")
        parsed = [parse_row(x) for x in lines]
        readings = rows_to_readings(parsed, logger)
        store.commit_chunk(logger, readings, parsed[-1].key)
        chunks.append((logger, readings))
    took = time.perf_counter() - started
    CPU.setdefault("ingest", []).append(time.process_time() - cpu)
    for _, readings in chunks:  # the channels' names, as a download gives them
        readings[:] = [replace(r, name=NAMES[r.channel]) for r in readings]
    return took, chunks


def alarms(
    path: Path, plan: AlarmPlan, downloads: list[Chunks], fast: bool
) -> tuple[list[float], int]:
    """The alarm path's time for each download, and the transitions it made; the collector
    restarts before the last download (its alarms come back from the store)."""
    store = AlarmStore(path).open()
    core = Alarms(plan, store.load_states())
    policy = Policy(plan, store, UTC)
    times: list[float] = []
    transitions = 0
    for n, chunks in enumerate(downloads):
        if n == len(downloads) - 1:
            store.close()
            store = AlarmStore(path).open()
            core = Alarms(plan, store.load_states())
            policy = Policy(plan, store, UTC)
        settle_heap()
        started = time.perf_counter()
        for logger, readings in chunks:
            if fast:
                out = core.ingest(logger, readings)
            else:
                out = core.readings([Sample.of(logger, r) for r in readings])
            with store.transaction():
                if out:
                    store.record(out)
                    policy.notify(out, out[-1].time)
                if fast:
                    store.save_changes(core.changes())
                else:
                    store.save_states(core.changed())
            transitions += len(out)
        times.append(time.perf_counter() - started)
    store.close()
    return times, transitions


def collector(tmp: Path, downloads: list[Chunks]) -> tuple[list[float], float]:
    """The collector's own path, :meth:`AlarmLoop.readings` (what the runner calls with each
    delivered batch: the fast evaluation, supply and signal health, repeats, one commit),
    for each download; the loop restarts before the last one (and how long it took to load
    the alarms back)."""
    config_path = tmp / "collector.toml"
    sources = "".join(
        f'[[source]]\nname = "{logger}"\nurl = "tcp://127.0.0.1:1"\n\n'
        for logger, _ in downloads[0]
    )
    config_path.write_text('[sqlite]\npath = "c.sqlite"\n\n' + sources + RULES)
    config = load_config(config_path)
    sqlite = SqliteStore(config.store).open_sync()
    loop = AlarmLoop(config)
    loop.open(sqlite, config.sources)
    times: list[float] = []
    restart = 0.0
    for n, chunks in enumerate(downloads):
        if n == len(downloads) - 1:
            loop.store.close()
            started = time.perf_counter()
            loop = AlarmLoop(config)
            loop.open(sqlite, config.sources)
            restart = time.perf_counter() - started
        settle_heap()
        started, cpu = time.perf_counter(), time.process_time()
        for logger, readings in chunks:
            loop.readings(logger, readings)
        times.append(time.perf_counter() - started)
        CPU.setdefault("collector", []).append(time.process_time() - cpu)
    loop.store.close()
    sqlite.close_sync()
    return times, restart


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loggers", type=int, default=1000)
    parser.add_argument("--minutes", type=int, default=10)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--paths",
        default="collector,alarms,samples",
        help="which alarm paths to run (comma-separated): collector, alarms, samples",
    )
    parser.add_argument(
        "--gc-all", action="store_true", help="let the garbage collector walk every object"
    )
    args = parser.parse_args()
    global FREEZE
    FREEZE = not args.gc_all
    print("load average: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    plan = parse_alarms(loads(RULES, Path("collector.toml")))
    texts = [rows(args.loggers, args.minutes, k * args.minutes) for k in range(3)]
    total = args.loggers * args.minutes * 12
    paths = args.paths.split(",")
    runs: dict[str, list[list[float]]] = {}
    restarts: list[float] = []
    transitions = 0
    for _ in range(args.repeat):
        CPU.clear()
        with tempfile.TemporaryDirectory() as tmp:
            store = SqliteStore(Path(tmp) / "ingest.sqlite").open_sync()
            downloads = [ingest(store, text) for text in texts]
            store.close_sync()
            chunks = [c for _, c in downloads]
            got = {"ingest": [t for t, _ in downloads]}
            if "alarms" in paths:
                got["alarms"], transitions = alarms(Path(tmp) / "a.sqlite", plan, chunks, True)
            if "samples" in paths:
                got["samples"], reference = alarms(Path(tmp) / "s.sqlite", plan, chunks, False)
                assert "alarms" not in paths or transitions == reference, reference
            if "collector" in paths:
                got["collector"], restart = collector(Path(tmp), chunks)
                restarts.append(restart)
                got["collector cpu"] = CPU["collector"]
            got["ingest cpu"] = CPU["ingest"]
        gc.unfreeze()  # this run's data may go
        for key, times in got.items():
            runs.setdefault(key, []).append(times)
    best = {key: [min(column) for column in zip(*rs, strict=True)] for key, rs in runs.items()}
    median = {
        key: [statistics.median(c) for c in zip(*rs, strict=True)] for key, rs in runs.items()
    }

    print(
        f"{args.loggers:,} loggers x 12 channels, {len(plan.rules)} rules each, "
        f"{total:,} readings a download, best (median) of {args.repeat}"
    )
    print(f"{'':32}{'first download':>22}{'next download':>24}{'after a restart':>24}")
    labels = {
        "ingest": "ingest (parse + commit)",
        "collector": "collector (AlarmLoop.readings)",
        "alarms": "alarms (ingest + store)",
        "samples": "alarms (Sample, whole rows)",
        "ingest cpu": "ingest, process CPU",
        "collector cpu": "collector, process CPU",
    }
    for key, label in labels.items():
        if key not in best:
            continue
        cells = "".join(
            f"{t:7.3f} ({m:.3f}) s {total / t:>9,.0f}/s "
            for t, m in zip(best[key], median[key], strict=True)
        )
        print(f"  {label:30}{cells}")
    if "alarms" in paths:
        print(f"  transitions: {transitions:,}")
    if restarts:
        print(
            f"  collector restart: states loaded in {min(restarts):.3f} "
            f"({statistics.median(restarts):.3f}) s"
        )
    for key in ("collector", "alarms", "samples", "collector cpu"):
        if key not in best:
            continue
        base = "ingest cpu" if key.endswith("cpu") else "ingest"
        ratios = "   ".join(
            f"{a / i:.3f} ({ma / mi:.3f})"
            for a, i, ma, mi in zip(best[key], best[base], median[key], median[base], strict=True)
        )
        print(f"  {key} : {base} = {ratios} (first, next, after a restart; goal <= 0.10)")


if __name__ == "__main__":
    main()

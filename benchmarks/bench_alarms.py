"""Benchmark: the cost of alarm rules at ingest (issue 21: at most 10 % of the ingest rate).

1,000 loggers x 12 channels, 10 rules that apply to every logger (thresholds above and
below with hysteresis, stuck, step, on named and numbered channels, globs on the logger),
fed the readings of a download: one row of 12 channels per logger per minute.

Two figures over the same readings, in download-sized chunks:

- ``ingest``: the collector's host path after the line: record rows parsed
  (:func:`parse_row`), turned into readings (:func:`rows_to_readings`) and committed with
  the source's cursor (:meth:`SqliteStore.commit_chunk`), as ``bench_ingest_sqlite.py``;
- ``alarms``: the same readings through the alarm core: each reading made a
  :class:`~sondalog.collect.alarms.Sample` and evaluated by :meth:`Alarms.readings`
  against every rule, then the transitions recorded and the notifications queued in the
  alarm store, in one transaction per chunk (the readings cross their limits now and then,
  so alarms are raised and cleared throughout).

The ratio alarms : ingest is the goal's figure (<= 0.10).

Run: ``.venv/bin/python benchmarks/bench_alarms.py [--loggers 1000] [--minutes 10]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path

from sondalog.client.records import parse_row
from sondalog.collect.alarms import Alarms, AlarmStore, Policy, Sample, parse_alarms
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


def rows(loggers: int, minutes: int) -> dict[str, list[str]]:
    """Each logger's record rows: 12 channels a row, one row a minute."""
    out: dict[str, list[str]] = {}
    for n in range(loggers):
        lines = []
        for i in range(minutes):
            stamp = (T0 + timedelta(seconds=60 * i)).strftime("%Y%m%d%H%M%S")
            fields = ",".join(f"{(i * 7 + ch * 13 + n) % 2500 / 1000:.3f}" for ch in range(12))
            lines.append(f"{stamp}.0,1,{fields}")
        out[f"F{n:04}"] = lines
    return out


def samples(source: str, readings: list[Reading]) -> list[Sample]:
    """Readings as the alarm core takes them (the collector's conversion)."""
    return [
        Sample(
            source,
            r.logger,
            r.channel,
            r.value,
            (r.utc or r.time.replace(tzinfo=UTC)).timestamp(),
            r.name,
            r.counter,
        )
        for r in readings
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loggers", type=int, default=1000)
    parser.add_argument("--minutes", type=int, default=10)
    args = parser.parse_args()
    per_logger = rows(args.loggers, args.minutes)
    total = args.loggers * args.minutes * 12
    plan = parse_alarms(loads(RULES, Path("collector.toml")))
    names = {ch: f"T{ch}" for ch in range(1, 13)}
    with tempfile.TemporaryDirectory() as tmp:
        store = SqliteStore(Path(tmp) / "ingest.sqlite").open_sync()
        chunks: list[tuple[str, list[Reading]]] = []
        started = time.perf_counter()
        for logger, lines in per_logger.items():
            store.add_source(logger, f"tcp://x:{logger}", "logger")
            parsed = [parse_row(x) for x in lines]
            readings = rows_to_readings(parsed, logger)
            store.commit_chunk(logger, readings, parsed[-1].key)
            chunks.append((logger, readings))
        ingest = time.perf_counter() - started
        store.close_sync()
        for _, readings in chunks:  # the channels' names, as a download gives them
            readings[:] = [
                r.__class__(**{**_fields(r), "name": names[r.channel]}) for r in readings
            ]

        alarms_store = AlarmStore(Path(tmp) / "alarms.sqlite").open()
        alarms = Alarms(plan, alarms_store.load_states())
        policy = Policy(plan, alarms_store, UTC)
        transitions = 0
        started = time.perf_counter()
        for logger, readings in chunks:
            out = alarms.readings(samples(logger, readings))
            with alarms_store.transaction():
                if out:
                    alarms_store.record(out)
                    policy.notify(out, out[-1].time)
                alarms_store.save_states(alarms.changed())
            transitions += len(out)
        evaluate = time.perf_counter() - started
        alarms_store.close()

    print(
        f"{args.loggers:,} loggers x 12 channels, {len(plan.rules)} rules each, {total:,} readings"
    )
    print(f"  ingest (parse + commit):   {ingest:6.2f} s  {total / ingest:>10,.0f} readings/s")
    print(f"  alarms (evaluate + store): {evaluate:6.2f} s  {total / evaluate:>10,.0f} readings/s")
    print(f"  transitions: {transitions:,}")
    print(f"  alarms : ingest = {evaluate / ingest:.3f} (goal <= 0.10)")


def _fields(r: Reading) -> dict[str, object]:
    return {f: getattr(r, f) for f in Reading.__dataclass_fields__}


if __name__ == "__main__":
    main()

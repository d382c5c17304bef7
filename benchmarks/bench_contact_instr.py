"""Benchmark: the collector's instructions a contact, counted by callgrind (issue 24).

On a shared machine whose speed varies by the minute, CPU time a contact moves by tens of
per cent between runs; instructions do not. A fleet of ``--loggers`` virtual loggers
(``sondalog serve``, its own process, not counted; four channels every 60 s) is contacted by
``--loggers`` sources every ``--interval`` seconds, by the collector's own code
(:class:`~sondalog.collect.runner.Collector`, the store in a temporary directory, no
dashboard) under ``valgrind --tool=callgrind``, until it has made ``N`` contacts, for the two
``--contacts`` counts. The difference of the two runs' instructions over the difference of
their contacts is the instructions of a contact, without the start, the imports and the
first contacts (each of which downloads a record from its start).

Each tree (this one, ``--compare OLD_SRC``) is measured on the default path and, with
``--keep-open``, with ``keep_open = true`` on every source, against the same fleet. Under
valgrind the collector is about fifty times slower: keep it unsaturated (the defaults, 10
sources every 2 s), or the work that follows the wall clock (the store's flush a second,
``contacting`` marks of contacts that wait for the loop more than a second) grows with the
machine's load and is counted as the contacts'.

    .venv/bin/python benchmarks/bench_contact_instr.py --compare /tmp/base/src --keep-open
"""

from __future__ import annotations

import argparse
import asyncio
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_collect_fleet import config_text, start
from bench_fleet import configure

HERE = Path(__file__).resolve().parent.parent / "src"

#: Runs the collector of the file in argv[2] until it has made argv[1] contacts.
DRIVER = """
import asyncio, sys
from pathlib import Path
from sondalog.collect.config import load_config
from sondalog.collect.runner import Collector
from sondalog.io.loop import run

wanted = int(sys.argv[1])
collector = Collector(load_config(Path(sys.argv[2])))
collector.open()

async def main():
    stop = asyncio.Event()
    async def watch():
        while collector.contacts < wanted:
            await asyncio.sleep(0.5)
        stop.set()
    task = asyncio.create_task(watch())
    await collector.run(stop)
    await task

run(main())
print(collector.contacts)
"""


def instructions(out: Path) -> int:
    for line in out.read_text().splitlines():
        if line.startswith(("summary:", "totals:")):
            return int(line.split()[1])
    raise RuntimeError(f"no totals in {out}")


def measure(
    src: Path, ports: list[int], count: int, args: argparse.Namespace, keep: bool
) -> tuple[int, int]:
    """(instructions, contacts) of one collector run to ``count`` contacts."""
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "collector.toml"
        config.write_text(config_text(ports, args.interval, 0, keep))
        out = Path(tmp) / "callgrind.out"
        done = subprocess.run(
            [
                "valgrind",
                "--tool=callgrind",
                f"--callgrind-out-file={out}",
                sys.executable,
                "-c",
                DRIVER,
                str(count),
                str(config),
            ],
            env={**os.environ, "PYTHONPATH": str(src)},
            capture_output=True,
            text=True,
            check=True,
        )
        return instructions(out), int(done.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loggers", type=int, default=10)
    parser.add_argument("--interval", type=float, default=2.0)
    parser.add_argument("--contacts", type=int, nargs=2, default=[60, 260])
    parser.add_argument("--compare", type=Path, help="another tree's src/ (before)")
    parser.add_argument("--keep-open", action="store_true", help="also keep_open = true")
    parser.add_argument("--runs", type=int, default=1)
    args = parser.parse_args()
    trees = [("this tree", HERE, False)]
    if args.keep_open:
        trees.append(("this tree, keep_open", HERE, True))
    if args.compare:
        trees.append(("compare", args.compare, False))
        if args.keep_open:
            trees.append(("compare, keep_open", args.compare, True))
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp) / "fleet"
        work.mkdir()
        fleet, ports, _ = start(args.loggers, work)
        try:
            asyncio.run(configure(ports, 4))
            print(
                f"{args.loggers} sources every {args.interval:g} s, 4 channels; "
                f"contacts {args.contacts[0]} and {args.contacts[1]}"
            )
            print("| tree | instructions a contact | contacts |")
            print("|---|---|---|")
            for index in range(args.runs):
                for label, src, keep in trees if index % 2 == 0 else trees[::-1]:
                    low = measure(src, ports, args.contacts[0], args, keep)
                    high = measure(src, ports, args.contacts[1], args, keep)
                    per = (high[0] - low[0]) / max(high[1] - low[1], 1)
                    print(f"| {label} | {per:,.0f} | {low[1]}, {high[1]} |", flush=True)
        finally:
            fleet.terminate()
            fleet.wait(timeout=60)


if __name__ == "__main__":
    main()

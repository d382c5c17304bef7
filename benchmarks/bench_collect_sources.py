"""Benchmark: many logger sources polled by one collector process (goal: 1,000 sources).

Serves ``--loggers`` virtual loggers (each sampling two channels every 10 s of module time at
``--speed``) and runs ``sondalog collect`` with ``--sources`` logger sources spread over them
(every TCP connection is its own line of a served logger, so many sources may share one), each
with ``interval = --interval`` seconds. After ``--seconds`` it reads the store and prints the
contacts made, how many sources were contacted at least twice, errors, and the collector's CPU
time per contact.

Run: ``.venv/bin/python benchmarks/bench_collect_sources.py [--sources 1000] [--interval 20]``.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import select
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLI = [sys.executable, "-m", "sondalog"]
SITE = """[logger]
[[logger.analog]]
address = 16
signal = { model = "sine", mean = 1.2, amplitude = 1.0, period = 600 }
"""


def serve(tmp: Path, index: int, speed: float) -> tuple[subprocess.Popen[bytes], str]:
    site = tmp / "site.toml"
    site.write_text(SITE)
    proc = subprocess.Popen(
        [
            *CLI,
            "logger",
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--state",
            str(tmp / f"l{index}"),
            "--serial-number",
            f"{index + 1:06d}",
            "--site",
            str(site),
            "--speed",
            str(speed),
        ],
        stdout=subprocess.PIPE,
    )
    assert proc.stdout is not None and select.select([proc.stdout], [], [], 15)[0]
    line = proc.stdout.readline().decode()
    url = "tcp://" + line.removeprefix("listening on ").strip()
    subprocess.run(
        [*CLI, "term", url],
        input=(
            "write date 20070301000000\nwrite channel max number 2\n"
            "write channel 2 type 3 write channel 2 address 16 write channel 2 switch output 0\n"
            "write channel sampling period 000010 000010\n"
        ),
        text=True,
        check=True,
        capture_output=True,
    )
    return proc, url


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sources", type=int, default=1000)
    parser.add_argument("--loggers", type=int, default=4)
    parser.add_argument("--interval", type=float, default=20.0)
    parser.add_argument("--seconds", type=float, default=50.0)
    parser.add_argument("--speed", type=float, default=10.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        servers = [serve(tmp, i, args.speed) for i in range(args.loggers)]
        try:
            config = tmp / "collector.toml"
            config.write_text(
                '[sqlite]\npath = "store.sqlite"\n'
                + "".join(
                    f'\n[[source]]\nurl = "{servers[i % len(servers)][1]}"\nname = "s{i:04d}"\n'
                    f"interval = {args.interval}\nretry = 2\nretry_max = 10\n"
                    for i in range(args.sources)
                )
            )
            collector = subprocess.Popen([*CLI, "collect", str(config)], stderr=subprocess.DEVNULL)
            time.sleep(args.seconds)
            cpu = cpu_seconds(collector.pid)
            collector.send_signal(signal.SIGTERM)
            collector.wait(timeout=60)
            with contextlib.closing(sqlite3.connect(tmp / "store.sqlite")) as db:
                ok = dict(
                    db.execute(
                        "SELECT source, count(*) FROM events "
                        "WHERE kind = 'download' GROUP BY source"
                    ).fetchall()
                )
                errors = db.execute("SELECT count(*) FROM events WHERE kind = 'error'").fetchone()[
                    0
                ]
                readings = db.execute("SELECT count(*) FROM readings").fetchone()[0]
        finally:
            for proc, _ in servers:
                proc.send_signal(signal.SIGTERM)
                proc.wait(timeout=10)
    contacts = sum(ok.values())
    twice = sum(1 for n in ok.values() if n >= 2)
    print(
        f"{args.sources} sources on {args.loggers} served loggers, interval {args.interval:g} s, "
        f"{args.seconds:g} s of running:"
    )
    print(
        f"  contacts: {contacts:,} ({contacts / args.seconds:.1f}/s; the schedule asks "
        f"{args.sources / args.interval:.1f}/s), errors: {errors}"
    )
    print(f"  sources contacted at least twice: {twice} of {args.sources}")
    print(f"  readings stored: {readings:,}")
    print(
        f"  collector CPU: {cpu:.1f} s ({cpu / max(contacts, 1) * 1000:.1f} ms per contact, "
        f"{cpu / args.seconds:.0%} of one core)"
    )


if __name__ == "__main__":
    main()

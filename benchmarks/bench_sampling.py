"""Benchmark: simulated logging and record reads through the pure ALA1 engine (issues 3, 24).

Prints:
1. a year of module time for 12 channels sampled every minute, with averaging (10 samples)
   and change conditions on, every channel alike and nothing switched (the uniform
   configuration): wall-clock seconds, samples and rows per second (issue 11's goal: a year
   in at most 5 s), best and median of ``--runs`` years;
1b. a year of the realistic logger of issue 24: the seven inputs of
   ``examples/logger-site.toml`` (a switched analog sensor with a switch-on delay, two
   DS18B20, a rain gauge, supply, GSM signal and credit) on 12 channels every minute with
   averaging, conversion tables (1-D, a second table, 2-D), pulse counts and events, record
   conditions, and a message on a threshold sent by SMS (goal: a year in at most 5 s);
   ``--periods`` adds a variant whose channels sample at 1, 5 and 10 minutes;
2. the cost of ``read record 1000 from date/.../`` on a full 1 MiB cyclic record;
3. bytes per second of ``read record 100000 from start``.

Wall time is what the goals count; CPU time (of this process) is printed beside it, as the
machine may be shared.

Run: ``.venv/bin/python benchmarks/bench_sampling.py [--runs N] [--only uniform|realistic]
[--periods] [--dir DIR]``
(``make bench`` runs every benchmark).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from sondalog.ala1 import Engine, Identity, Version
from sondalog.ala1.hardware import Hardware
from sondalog.ala1.record import row_key
from sondalog.backends.sim.logger import Analog, SimHardware
from sondalog.backends.sim.logger_site import load_logger_site
from sondalog.backends.sim.signals import RandomWalk, sine
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.protocol.tables import build_files

T0 = 1_000_000_000.0
ADDRESSES = (16, 17, 18, 19, 20, 24)
DAYS = 365
SITE = Path(__file__).resolve().parent.parent / "examples" / "logger-site.toml"


def uniform_hardware() -> SimHardware:
    return SimHardware(
        analog=[
            Analog(a, sine(1.0, 0.8, 86400.0 / (i + 1), 0.0, T0))
            if i % 2
            else Analog(a, RandomWalk(1.0, 0.01, 60.0, i, T0, lambda v: min(2.4, max(0.0, v))))
            for i, a in enumerate(ADDRESSES)
        ]
    )


def logger(db: Path, hardware: Hardware | None = None) -> tuple[Engine, int]:
    hw = uniform_hardware() if hardware is None else hardware
    engine = Engine(Identity(Version.V2_10), SqliteNvStore(db), T0, hw)
    return engine, engine.open_line()


def ask(engine: Engine, line: int, command: str, now: float = T0) -> bytes:
    return b"".join(o.data for o in engine.receive(line, command.encode() + b"\r", now))


def configure(engine: Engine, line: int) -> None:
    for command in (
        "write date 20070101000000",
        "write channel max number 12",
    ):
        assert ask(engine, line, command) == b"OK\r\n"
    for ch in range(1, 13):
        for part in (
            f"type 3 write channel {ch} address {ADDRESSES[ch % 6]}",
            f"switch output 0 write channel {ch} format 0.3",
            f"sampling period 000100 write channel {ch} sampling start 20070101000000",
            f"average samples 10 write channel {ch} record change 0.02",
        ):
            assert ask(engine, line, f"write channel {ch} {part}") == b"OK\r\n", part


# -- the realistic logger (issue 24) --------------------------------------------------------
#: Conversion tables: water level (V -> cm), a thermometer's correction, mm per volt (a
#: second table) and a level compensated by temperature (2-D: V, °C -> mm).
TABLES = {
    "level": b"0 0\n0.5 40\n1.0 95\n1.5 160\n2.0 230\n2.5 310\n",
    "corr": b"-55 -55.2\n0 0.1\n50 50.3\n125 125.6\n",
    "mm": b"0 0\n1000 1000\n",
    "comp": b"0\n0 0\n2.5 2500\n20\n0 0\n2.5 2520\n40\n0 0\n2.5 2540\n",
}
ROM = "47123456789ABC28"  # the first DS18B20 of the site file
#: The twelve channels: the site's seven inputs, some read twice (a table, a second unit).
CHANNELS = (
    # 1-2 the water level, powered by output 2 five seconds before each sample
    "type 3|address 16|switch output 2|switch advance 5|format 0.3|average samples 10"
    "|record change 0.01",
    "type 3|address 16|switch output 2|switch advance 5|convert 1 file name/level/"
    "|format 0.1|average samples 10|record samples 10",
    # 3-4 the DS18B20 pair: by ROM code, and the only sensor of its pin
    f"type 3|device 3|address x {ROM}|switch output 0|format 0.2|average samples 5"
    "|record change 0.1",
    "type 3|device 5|address 0|switch output 0|format 0.1|average samples 5"
    "|record change 0.1|record samples 60",
    # 5-6 the rain gauge: pulses averaged, and events (type 6)
    "type 2|device 4|format 0.0|average samples 10|record change 1",
    "type 6|device 4|format 0.0|record change 1",
    # 7 the supply, its divider switched by output 1 (factory advance 1 s)
    "type 1|address 21|switch output 1|switch advance 1|format 0.1|average samples 10"
    "|record change 0.1",
    # 8-9 GSM signal and credit
    "type 12|format 0.0|average samples 10|record change 1",
    "type 11|format 0.2|record change 0.5|record samples 1440",
    # 10 the level in mm through a second table; 11 a corrected temperature
    "type 3|address 16|switch output 2|switch advance 5|cal mult value 1000"
    "|convert 2 file name/mm/|format 0.0|average samples 10|record change 5",
    f"type 3|device 3|address x {ROM}|switch output 0|convert 1 file name/corr/"
    "|format 0.2|average samples 10|record change 0.1",
    # 12 the level compensated by the temperature: a 2-D table over both inputs
    f"type 9|device all 1,3|address all x 10,{ROM}|switch output all 2,0"
    "|switch advance all 5,0|convert 1 file name/comp/|format 0.0|average samples 10"
    "|record change 5",
)
#: Sampling periods of the ``--periods`` variant, by channel.
MIXED_PERIODS = ("000100", "000100", "001000", "001000", "000100", "000100", "000500",
                 "001000", "001000", "000100", "001000", "000500")  # fmt: skip


def configure_realistic(engine: Engine, line: int, periods: tuple[str, ...] | None = None) -> None:
    """The realistic logger, set up through the protocol as a user would."""

    def ok(command: str) -> None:
        assert ask(engine, line, command) == b"OK\r\n", command

    ok("write date 20070101000000 write channel max number 12")
    ok("write file record size 983040 write file list size 256 write file data size 51200")
    listing, data = build_files(TABLES)
    engine.state.write_file("list", listing)
    engine.state.write_file("data", data)
    ok("write device 3 type ds18b20 write device 3 address 4")
    ok("write device 5 type ds18b20 write device 5 address 5")
    ok("write device 4 type msp430ta")
    ok("write output 2 device 1 write output 2 address 6")
    for ch, spec in enumerate(CHANNELS, 1):
        for part in spec.split("|"):
            ok(f"write channel {ch} {part}")
        period = "000100" if periods is None else periods[ch - 1]
        ok(f"write channel {ch} sampling period {period}")
        ok(f"write channel {ch} sampling start 20070101000000")
    # a message on a threshold: the level rising above 1.5 (hysteresis 0.2) sends an SMS
    ok("write com device wavecom41 write address 1 type sms 1 value/+420700000001/")
    ok("write command 1 value|read channel 1 value read record 3 from end|")
    ok("write message 1 address 1 write message 1 command 1")
    ok("write message 1 of channel function up write message 1 of channel number 1")
    ok("write message 1 of channel value 1.5 write message 1 of channel hysteresis 0.2")
    ok("write com close")


def simulate_year(engine: Engine) -> tuple[float, float, int, int]:
    """Wall and CPU time of one simulated year, rows written, messages sent (an SMS carrier
    takes each sending at the end of each simulated day and reports it delivered)."""
    first = engine.state.record.next_seq
    sent = 0
    start, cpu = time.perf_counter(), time.process_time()
    for day in range(1, DAYS + 1):  # one advance per simulated day, each a group commit
        engine.advance(T0 + day * 86400)
        while (outgoing := engine.outbox.take()) is not None:
            sent += 1
            engine.outbox.done(outgoing.ident, True)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    return elapsed, cpu, engine.state.record.next_seq - first, sent


def realistic_year(
    db: Path, periods: tuple[str, ...] | None = None
) -> tuple[float, float, Engine, int, int]:
    """Wall and CPU time of a year of the realistic logger, the engine, rows, messages."""
    engine, line = logger(db, load_logger_site(SITE, T0))
    configure_realistic(engine, line, periods)
    elapsed, cpu, written, sent = simulate_year(engine)
    return elapsed, cpu, engine, written, sent


def _figures(title: str, runs: list[tuple[float, float]], samples: int) -> float:
    walls, cpus = [w for w, _ in runs], [c for _, c in runs]
    best, median = min(walls), statistics.median(walls)
    print(title)
    goal = f"(goal <= 5 s: {best <= 5.0})"
    print(
        f"   wall time            {best:8.2f} s best, {median:.2f} s median of {len(runs)}  {goal}"
    )
    cpu, cpu_median = min(cpus), statistics.median(cpus)
    print(f"   CPU time             {cpu:8.2f} s best, {cpu_median:.2f} s median")
    print(f"   channel samples / s  {samples / best:12,.0f}")
    return best


def bench_year(tmp: Path, runs: int) -> None:
    figures = []
    for run in range(runs):
        engine, line = logger(tmp / f"year{run}.sqlite")
        configure(engine, line)
        elapsed, cpu, written, _ = simulate_year(engine)
        figures.append((elapsed, cpu))
    samples = DAYS * 1440 * 12
    status = ask(engine, line, "read record status", T0 + DAYS * 86400).decode().split()[0]
    rows = len(engine.state.record)
    title = "1. one year, 12 channels sampled every minute, averaging 10, change 0.02"
    best = _figures(title, figures, samples)
    print(f"   rows written / s     {written / best:12,.0f}   ({written:,} rows in the year)")
    print(f"   module time speed-up {DAYS * 86400 / best:12,.0f} x")
    print(f"   record               {status} ({rows} rows kept, cyclic 1 MiB)")


def bench_realistic(tmp: Path, runs: int, periods: tuple[str, ...] | None = None) -> None:
    figures = []
    for run in range(runs):
        db = tmp / f"real{run}{'' if periods is None else 'mixed'}.sqlite"  # a new logger each
        elapsed, cpu, engine, written, sent = realistic_year(db, periods)
        figures.append((elapsed, cpu))
    per_day = sum(86400 // _seconds(p) for p in periods) if periods else 12 * 1440
    what = "1, 5 and 10 minutes" if periods else "every minute"
    best = _figures(
        f"1b. one year of the realistic logger (logger-site.toml), 12 channels {what}",
        figures,
        DAYS * per_day,
    )
    print(f"   rows written / s     {written / best:12,.0f}   ({written:,} rows in the year)")
    print(f"   messages sent        {sent:12,}")
    print(f"   record               {engine.state.record.status()}")


def _seconds(period: str) -> int:
    return int(period[:2]) * 3600 + int(period[2:4]) * 60 + int(period[4:])


def full_record(tmp: Path) -> tuple[Engine, int, float]:
    engine, line = logger(tmp / "full.sqlite")
    configure(engine, line)
    for ch in range(1, 13):
        ask(
            engine, line, f"write channel {ch} average samples 0 write channel {ch} record change 0"
        )
    now = T0
    while "FULL" not in ask(engine, line, "read record status", now).decode():
        now += 86400
        engine.advance(now)
    return engine, line, now


def bench_reads(tmp: Path) -> None:
    engine, line, now = full_record(tmp)
    record = engine.state.record
    rows = len(record)
    middle = row_key(record.rows(rows // 2, 1)[0])[:14]
    runs = 50
    start = time.perf_counter()
    for _ in range(runs):
        answer = ask(engine, line, f"read record 1000 from date/{middle}/", now)
    per_read = (time.perf_counter() - start) / runs
    print(f"2. read record 1000 from date/{middle}/ on a full 1 MiB record ({rows} rows)")
    print(f"   {per_read * 1000:8.2f} ms per command, {len(answer):,} bytes answered")

    start = time.perf_counter()
    answer = ask(engine, line, "read record 100000 from start", now)
    elapsed = time.perf_counter() - start
    print(f"3. read record 100000 from start: {len(answer):,} bytes ({rows} rows)")
    print(
        f"   {elapsed * 1000:8.1f} ms, {len(answer) / elapsed / 1e6:8.1f} MB/s through the engine"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="years simulated (best, median)")
    parser.add_argument("--only", choices=("uniform", "realistic"), help="one year benchmark")
    parser.add_argument("--periods", action="store_true", help="also mixed sampling periods")
    parser.add_argument(
        "--dir",
        help="where the loggers' state files go (default: the system's temporary directory; "
        "/dev/shm leaves the disk's fsync of each day's group commit out)",
    )
    args = parser.parse_args()
    runs = max(1, args.runs)
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        if args.only != "realistic":
            bench_year(Path(tmp), runs)
        if args.only != "uniform":
            bench_realistic(Path(tmp), runs)
            if args.periods:
                bench_realistic(Path(tmp), runs, MIXED_PERIODS)
        if args.only is None:
            bench_reads(Path(tmp))


if __name__ == "__main__":
    main()

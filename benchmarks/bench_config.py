"""How long ``logger config`` takes on one logger over TCP on loopback (issue 22).

Not a test (DESIGN.md "Benchmarks"): prints best and median of ``--runs`` runs. Run with
``.venv/bin/python benchmarks/bench_config.py [--runs N]``.

- pull: every setting read (chained reads packed into 120-character lines) and the file written;
- plan: the same reads and the comparison with a file of the demo's field logger;
- apply (fresh): that file applied to a factory-fresh logger, every write read back;
- fleet of 50: the file applied to 50 fresh loggers, 8 at a time.

Loggers are served in this process (``app.logger.start_logger``), the client too.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import tempfile
import time
from collections.abc import Awaitable, Callable
from pathlib import Path

from sondalog.ala1 import Version
from sondalog.app.demo_world import RAIN
from sondalog.app.explain import explain
from sondalog.app.logger import Logger, start_logger
from sondalog.client import Ala1Client
from sondalog.client.station_apply import apply, make_plan, pull
from sondalog.client.station_file import read_station
from sondalog.client.station_fleet import Target, run_fleet
from sondalog.config import loads
from sondalog.io.clock import RealClock


def _explain(line: str, version: str) -> str:
    return explain(line, version).render()


async def _logger(state: Path, version: str) -> tuple[Logger, str]:
    logger = await start_logger(state, RealClock(), ("127.0.0.1", 0), Version(version))
    host, port = logger.servers[0].address
    return logger, f"tcp://{host}:{port}"


async def _timed(work: Callable[[], Awaitable[object]]) -> float:
    start = time.perf_counter()
    await work()
    return time.perf_counter() - start


async def bench(version: str, runs: int, tmp: Path) -> dict[str, list[float]]:
    figures: dict[str, list[float]] = {"pull": [], "plan": [], "apply (fresh)": []}
    demo, url = await _logger(tmp / f"demo{version}", version)
    async with await Ala1Client.connect(url) as client:
        for line in RAIN.settings:
            (await client.command(line)).raise_for_error()
    text, _ = await pull(url)
    station = read_station(loads(text))
    for run in range(runs):
        figures["pull"].append(await _timed(lambda: pull(url)))
        figures["plan"].append(await _timed(lambda: make_plan(url, station)))
        fresh, fresh_url = await _logger(tmp / f"fresh{version}-{run}", version)
        figures["apply (fresh)"].append(
            await _timed(lambda: apply(fresh_url, station, _explain))  # noqa: B023
        )
        await fresh.close()
    await demo.close()
    return figures


async def bench_fleet(tmp: Path, runs: int) -> list[float]:
    station = read_station(loads('[channel.2]\nname = "Hladina"\nsampling_period = "000500"\n'))
    times = []
    for run in range(runs):
        loggers = [await _logger(tmp / f"f{run}-{n}", "2.10") for n in range(50)]
        targets = [Target(url, station) for _, url in loggers]
        times.append(await _timed(lambda: run_fleet(targets, _explain, 8)))  # noqa: B023
        for logger, _ in loggers:
            await logger.close()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for version in ("2.10", "1.16"):
            for name, times in asyncio.run(bench(version, args.runs, Path(tmp))).items():
                print(
                    f"{version} {name:14} best {min(times) * 1000:7.1f} ms"
                    f"  median {statistics.median(times) * 1000:7.1f} ms"
                )
        times = asyncio.run(bench_fleet(Path(tmp), max(1, args.runs // 2)))
        print(
            f"fleet of 50 (2.10, --parallel 8) best {min(times):.2f} s"
            f"  median {statistics.median(times):.2f} s"
        )


if __name__ == "__main__":
    main()

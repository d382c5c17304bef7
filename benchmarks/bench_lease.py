"""Benchmark: what sharing the sources through PostgreSQL costs (issue 24, docs/scaling.md).

Starts a throwaway PostgreSQL (Debian's, as ``nobody`` on a loopback port, like the tests),
puts 10,000 sources in the lease tables and lets three members take turns as
:class:`~sondalog.collect.share.Share` does (member row and snapshot, the pure plan, release,
renew, take). Prints, best and median of the turns once the split has settled:

- the wall time of one turn (what delays a member's renewals) and its CPU time in the
  collector (the share of a core at one turn every ``lease / 3`` = 10 s, the default for
  60 s intervals);
- the time of one cursor save (one per batch) over 2,000 saves.

Not a test: it prints figures.

    .venv/bin/python benchmarks/bench_lease.py [--sources 10000] [--members 3] [--turns 10]
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import time
from pathlib import Path

from sondalog.collect.lease_pg import LeaseTables
from sondalog.collect.leases import plan

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "collect"))
import services  # the tests' real-server helpers

PERIOD = 10.0  # lease 30 s / 3


async def turn(tables: LeaseTables, names: list[str]) -> tuple[float, float, int]:
    """One member's turn: (wall seconds, CPU seconds, sources held after)."""
    wall, cpu = time.perf_counter(), time.process_time()
    snap = await tables.snapshot(names)
    todo = plan(tables.me, names, snap.leases, snap.members, snap.now)
    await tables.release(todo.release)
    kept = await tables.renew(todo.keep)
    taken = await tables.take(todo.take, todo.want)
    return time.perf_counter() - wall, time.process_time() - cpu, len(kept) + len(taken)


async def run(dsn: str, sources: int, members: int, turns: int) -> None:
    names = [f"station-{i:05}" for i in range(sources)]
    tables = [LeaseTables(dsn, f"host-{i}:1:abc", lease=30.0) for i in range(members)]
    await tables[0].join(names)
    walls: list[float] = []
    cpus: list[float] = []
    for n in range(turns + 3):  # three rounds to settle the split
        for t in tables:
            wall, cpu, held = await turn(t, names)
            if n >= 3:
                walls.append(wall)
                cpus.append(cpu)
    held = [h for *_, h in [await turn(t, names) for t in tables]]
    saves: list[float] = []
    me = tables[0]
    mine = [s for s, lease in (await me.snapshot(names)).leases.items() if lease.holder == me.me]
    for i in range(2000):
        start = time.perf_counter()
        await me.save(mine[i % len(mine)], f"2026010100{i:04}.0", "F00001", contact=True)
        saves.append(time.perf_counter() - start)
    for t in tables:
        await t.leave()
        await t.close()
    ms = 1000.0
    print(f"{sources} sources, {members} members: held {held}")
    print(
        f"turn wall: best {min(walls) * ms:.1f} ms, median {statistics.median(walls) * ms:.1f} ms"
    )
    print(
        f"turn CPU (collector): best {min(cpus) * ms:.1f} ms, median "
        f"{statistics.median(cpus) * ms:.1f} ms = {statistics.median(cpus) / PERIOD:.2%} of a "
        f"core at one turn every {PERIOD:g} s"
    )
    print(
        f"cursor save: best {min(saves) * ms:.2f} ms, median {statistics.median(saves) * ms:.2f} ms"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sources", type=int, default=10_000)
    parser.add_argument("--members", type=int, default=3)
    parser.add_argument("--turns", type=int, default=10)
    args = parser.parse_args()
    bindir = services._pg_bin()
    if bindir is None:
        sys.exit("PostgreSQL binaries (/usr/lib/postgresql/*/bin) are not installed")
    server = services.PostgresServer(bindir)
    try:
        server.start()
        asyncio.run(run(server.create_db(), args.sources, args.members, args.turns))
    finally:
        server.destroy()


if __name__ == "__main__":
    main()

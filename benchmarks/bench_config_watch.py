"""Benchmark: what reading a logger's configuration adds to a collector's contact (issues 22, 24).

Serves one logger of each protocol version (``sondalog logger serve``, TCP on loopback, two
channels sampled) and makes contacts with the collector's own
:class:`~sondalog.collect.sources.LoggerSource` (download, channel types, record status), with
the configuration check off (``config_every = 0``) and on (every contact: read whole, compared
with the last one), in rounds of ten contacts each, interleaved. Each round runs in a child
process (``--compare OLD_SRC`` alternates this tree's code with another tree's, before and
after in the same minutes: ``git archive BASE src | tar -x -C /tmp/base``).

Prints per protocol version and tree, best and median: the wall time of a contact, the
collector's CPU per contact and the served logger's CPU per contact (``/proc``), off and on;
what the check adds (CPU, and as a multiple of the contact's own CPU); round trips (waits for
answers to lines sent; a window's further lines go as the answers flow in) and bytes sent and
received per check (on a 9600 baud line at least the larger of them x 10 bits / 9600); the
check's own collector CPU (measured around it, not a difference of two noisy figures) and
the collector's sleeps (voluntary context switches) a contact, steadier than CPU time on a
busy machine.

``--reads N``: the check's read alone (``read_config`` N times on one connection a round),
without contacts: the collector's CPU, wall and sleeps a read, the logger's CPU a read.

Run: ``.venv/bin/python benchmarks/bench_config_watch.py [--rounds 5] [--compare /tmp/base/src]
[--reads 100]``.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import select
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from loadgen import process_cpu

HERE = Path(__file__).resolve().parent.parent / "src"
SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]
CONTACTS = 10  # per round and setting
TRAFFIC = ("trips", "sent", "received")


def serve(tmp: Path, protocol: str) -> tuple[subprocess.Popen[bytes], str]:
    from sondalog.client import Client

    proc = subprocess.Popen(
        [*SERVE, "--listen", "127.0.0.1:0", "--state", str(tmp / protocol), "--protocol",
         protocol, "--speed", "20"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 20)
    line = proc.stdout.readline().decode() if ready else ""
    if not line.startswith("listening on "):
        proc.kill()
        raise SystemExit(f"the logger did not start: {line!r}")
    url = f"tcp://127.0.0.1:{int(line.rsplit(':', 1)[1])}"
    with Client(url) as client:
        for command in (
            f"write date {time.strftime('%Y%m%d%H%M%S')}",
            "write channel max number 2",
            "write channel sampling period 000010 000010",
        ):
            assert client.command(command, timeout=10).ok, command
    return proc, url


# -- the child: contacts with one tree's code ------------------------------------------------


def _count_traffic(counts: dict[str, float]) -> None:
    """Round trips and bytes of the client, whatever its version sends them with."""
    from sondalog.client import ala1

    pipeline, send_raw = ala1.Ala1Client.pipeline, ala1.Ala1Client.send_raw
    received = ala1._Stream.data_received

    async def counted_pipeline(self: Any, requests: Any, **kw: Any) -> Any:
        reqs = list(requests)
        counts["trips"] += 1
        counts["sent"] += sum(len(r if isinstance(r, str) else r.line()) + 1 for r in reqs)
        return await pipeline(self, reqs, **kw)

    async def counted_send(self: Any, data: bytes) -> None:
        counts["trips"] += 1
        counts["sent"] += len(data)
        await send_raw(self, data)

    def counted_received(self: Any, data: bytes) -> None:
        counts["received"] += len(data)
        received(self, data)

    from sondalog.collect.config_watch import ConfigWatch

    check = ConfigWatch.check

    async def counted_check(self: Any, client: Any) -> Any:
        before = dict(counts)
        cpu, sleeps = time.process_time(), _sleeps()
        try:
            return await check(self, client)
        finally:
            for key in TRAFFIC:
                counts[f"check_{key}"] += counts[key] - before[key]
            counts["check_cpu"] += time.process_time() - cpu  # the check alone, measured
            counts["check_sleeps"] += _sleeps() - sleeps

    counted = getattr(ala1.Ala1Client, "read_counted", None)  # not in older trees

    async def counted_read(self: Any, payload: bytes, *args: Any, **kw: Any) -> Any:
        counts["trips"] += 1  # one wait for the answers: the pieces go as they flow in
        counts["sent"] += len(payload) + sum(len(piece[-1]) for piece in kw.get("more", ()))
        return await counted(self, payload, *args, **kw)

    if counted is not None:
        ala1.Ala1Client.read_counted = counted_read  # type: ignore[method-assign]
    ala1.Ala1Client.pipeline = counted_pipeline  # type: ignore[method-assign]
    ala1.Ala1Client.send_raw = counted_send  # type: ignore[method-assign]
    ala1._Stream.data_received = counted_received  # type: ignore[method-assign]
    ConfigWatch.check = counted_check  # type: ignore[method-assign]


def _sleeps() -> int:
    """The process's voluntary context switches so far: each a wait for the line's bytes
    (or a timer), the wakes a check costs, steadier than CPU time on a loaded machine."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("voluntary_ctxt_switches:"):
                return int(line.split()[1])
    return 0


def child(url: str, store: str, every: int, count: int) -> None:
    from sondalog.collect.config import SourceConfig
    from sondalog.collect.model import Reading
    from sondalog.collect.sources import LoggerSource
    from sondalog.collect.store_sqlite import SqliteStore
    from sondalog.io.loop import run  # the collector's loop: uvloop when installed

    logging.getLogger("sondalog").setLevel(logging.ERROR)  # no hints about the idle logger
    counts: dict[str, float] = dict.fromkeys(
        [*TRAFFIC, *(f"check_{k}" for k in (*TRAFFIC, "cpu", "sleeps"))], 0
    )
    _count_traffic(counts)

    async def ignore(source: str, batch: list[Reading], cursor: str | None, **s: object) -> None:
        return None

    async def contacts() -> list[dict[str, float]]:
        config = SourceConfig(name=f"s{every}", url=url, config_every=every)
        sqlite = SqliteStore(Path(store)).open_sync()
        sqlite.add_source(config.name, url, "logger")
        source = LoggerSource(config, sqlite)
        await source.poll(ignore)  # the first contact of a process reads and compares all
        out = []
        try:
            for _ in range(count):
                counts.update(dict.fromkeys(counts, 0))
                start, cpu, sleeps = time.perf_counter(), time.process_time(), _sleeps()
                await source.poll(ignore)
                wall, cpu = time.perf_counter() - start, time.process_time() - cpu
                out.append({"wall": wall, "cpu": cpu, "sleeps": _sleeps() - sleeps, **counts})
        finally:
            sqlite.close_sync()
        return out

    print("ready", flush=True)
    sys.stdin.readline()
    print(json.dumps(run(contacts())), flush=True)


def reads_child(url: str, protocol: str, count: int) -> None:
    """``--reads``: the check's read alone (``read_config``), ``count`` times on one
    connection, as the collector's watch makes it; per read: CPU, wall, sleeps."""
    from sondalog.client import Ala1Client
    from sondalog.client.station_read import read_config
    from sondalog.io.loop import run

    async def reads() -> list[dict[str, float]]:
        client = await Ala1Client.connect(url)
        await read_config(client, protocol)
        out = []
        for _ in range(count):
            start, cpu, sleeps = time.perf_counter(), time.process_time(), _sleeps()
            await read_config(client, protocol)
            wall, cpu = time.perf_counter() - start, time.process_time() - cpu
            out.append({"wall": wall, "cpu": cpu, "sleeps": _sleeps() - sleeps})
        await client.close()
        return out

    print(json.dumps(run(reads())), flush=True)


def reads_only(trees: list[tuple[str, Path]], rounds: int, count: int) -> None:
    """``--reads N``: rounds of N reads a tree, interleaved, against one served logger of
    each version; the collector's CPU, wall and sleeps a read, the logger's CPU a read."""
    with tempfile.TemporaryDirectory() as tmp:
        for protocol in ("2.10", "1.16"):
            proc, url = serve(Path(tmp), protocol)
            got: dict[str, list[Any]] = {label: [] for label, _ in trees}
            logger: dict[str, list[float]] = {label: [] for label, _ in trees}
            try:
                for _ in range(rounds):
                    for label, src in trees:
                        before = process_cpu(proc.pid)
                        done = subprocess.run(
                            [sys.executable, __file__, "--reads-child", url, protocol,
                             str(count)],
                            env={**os.environ, "PYTHONPATH": str(src)}, capture_output=True,
                            check=True,
                        )  # fmt: skip
                        logger[label].append((process_cpu(proc.pid) - before) / (count + 1))
                        got[label] += json.loads(done.stdout)
            finally:
                proc.send_signal(signal.SIGTERM)
                proc.wait(timeout=10)
            for label, _ in trees:
                samples = got[label]
                print(
                    f"protocol {protocol}, {label}, {len(samples)} reads: collector CPU "
                    f"{ms([s['cpu'] for s in samples])} ms, wall {ms([s['wall'] for s in samples])}"
                    f" ms, sleeps {statistics.median(s['sleeps'] for s in samples):.0f} "
                    f"(median), logger CPU {ms(logger[label])} ms a read"
                )


def run_child(
    src: Path, url: str, store: Path, every: int, logger: int
) -> tuple[list[dict[str, float]], float]:
    """One round in a child process with ``src`` on its path; the samples and the logger's
    CPU seconds per contact while it ran them."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    proc = subprocess.Popen(
        [sys.executable, __file__, "--child", url, str(store), str(every), str(CONTACTS)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env,
    )  # fmt: skip
    assert proc.stdin is not None and proc.stdout is not None
    assert proc.stdout.readline().strip() == b"ready"
    before = process_cpu(logger)
    proc.stdin.write(b"go\n")
    proc.stdin.flush()
    samples = json.loads(proc.stdout.readline())
    used = process_cpu(logger) - before
    proc.wait(timeout=30)
    return samples, used / CONTACTS


# -- the parent ------------------------------------------------------------------------------


def ms(values: list[float]) -> str:
    return f"{min(values) * 1000:6.2f} / {statistics.median(values) * 1000:6.2f}"


def report(protocol: str, label: str, runs: dict[int, list[Any]]) -> None:
    (off, log_off), (on, log_on) = runs[0], runs[1]
    print(f"protocol {protocol}, {label}: best / median of {len(off)} contacts")
    for name, samples, logger in (("without the check", off, log_off), ("with it", on, log_on)):
        print(
            f"  contact {name:18}: wall {ms([s['wall'] for s in samples])} ms, collector CPU "
            f"{ms([s['cpu'] for s in samples])} ms, logger CPU {ms(logger)} ms"
        )
    cpu_off = statistics.median(s["cpu"] for s in off)
    added = statistics.median(s["cpu"] for s in on) - cpu_off
    best = min(s["cpu"] for s in on) - min(s["cpu"] for s in off)
    logger_added = statistics.median(log_on) - statistics.median(log_off)
    print(
        f"  the check adds: collector CPU {best * 1000:.2f} / {added * 1000:.2f} ms "
        f"({added / cpu_off:.2f}x the contact), logger CPU {logger_added * 1000:.2f} ms "
        f"({logger_added / statistics.median(log_off):.2f}x)"
    )
    alone = [s["check_cpu"] for s in on]
    print(
        f"  the check alone (measured around it): collector CPU {ms(alone)} ms "
        f"({statistics.median(alone) / cpu_off:.2f}x the contact without it)"
    )
    sleeps = [statistics.median(s.get("sleeps", 0) for s in run) for run in (off, on)]
    inside = statistics.median(s["check_sleeps"] for s in on)
    print(
        f"  sleeps (voluntary context switches) a contact, median: {sleeps[0]:.0f} without "
        f"the check, {sleeps[1]:.0f} with it ({inside:.0f} in the check)"
    )
    trips, sent, got = (statistics.median(s[f"check_{k}"] for s in on) for k in TRAFFIC)
    line = max(sent, got) * 10 / 9600
    print(
        f"  per check: {trips:.0f} round trips, {sent:.0f} bytes sent, {got:.0f} received "
        f"(>= {line:.1f} s at 9600 baud)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="rounds of 10 contacts each")
    parser.add_argument("--compare", type=Path, help="another tree's src/ (before)")
    parser.add_argument(
        "--reads", type=int, metavar="N", help="rounds of N reads alone, no contacts"
    )
    parser.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    parser.add_argument("--reads-child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        url, store, every, count = args.child
        child(url, store, int(every), int(count))
        return
    if args.reads_child:
        url, protocol, count = args.reads_child
        reads_child(url, protocol, int(count))
        return
    trees = [("this tree", HERE)] + ([("compare", args.compare)] if args.compare else [])
    print("load average: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    if args.reads:
        reads_only(trees, args.rounds, args.reads)
        print("load average: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
        return
    with tempfile.TemporaryDirectory() as tmp:
        for protocol in ("2.10", "1.16"):
            proc, url = serve(Path(tmp), protocol)
            runs: dict[str, dict[int, list[Any]]] = {
                label: {0: [[], []], 1: [[], []]} for label, _ in trees
            }
            try:
                for _ in range(args.rounds):
                    for label, src in trees:
                        for every in (0, 1):
                            store = Path(tmp) / f"{protocol}-{label}-{every}.sqlite"
                            samples, logger = run_child(src, url, store, every, proc.pid)
                            runs[label][every][0] += samples
                            runs[label][every][1].append(logger)
            finally:
                proc.send_signal(signal.SIGTERM)
                proc.wait(timeout=10)
            for label, _ in trees:
                report(protocol, label, runs[label])
        print("load average: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()

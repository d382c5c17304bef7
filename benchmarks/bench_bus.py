"""Benchmark: REPLY polls per second on a 9600-baud virtual bus with 32 HCTMPS1 modules.

Starts a real ``sondalog bus serve`` subprocess holding 32 temperature servers (each in
autonomous mode with this host on its distribution list, so some polls return data frames
and most return ``RREPLY.NODATA``), then grants ``REPLY`` round-robin over TCP for a while.

The theoretical maximum is what the line allows: each poll is a request frame, the module's
turnaround, and a reply frame, back to back, at 10 bit times per byte. The figure of merit is
achieved polls per second as a fraction of that maximum, for the frames actually exchanged
(target >= 90 %). Not a test: it prints figures.

    .venv/bin/python benchmarks/bench_bus.py [--seconds 10] [--modules 32] [--baud 9600]
"""

from __future__ import annotations

import argparse
import asyncio
import select
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sondalog.client.bus import BusMaster
from sondalog.hctmps1 import encode_frame
from sondalog.world.bus import DEFAULT_TURNAROUND


def site_text(modules: int, baud: int) -> str:
    lines = [f"[bus]\nbaud = {baud}\nseed = 1\n"]
    for i in range(modules):
        lines.append(
            f'[[bus.modules]]\nid = "N{i:02d}"\nkind = "temp"\n'
            f'signal = {{ model = "ramp", start = 10.0, rate = {0.01 * (i + 1)} }}\n'
        )
    return "\n".join(lines)


def start_server(state: Path, site: Path) -> tuple[subprocess.Popen[bytes], int]:
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sondalog",
            "bus",
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--state",
            str(state),
            "--site",
            str(site),
        ],
        stdout=subprocess.PIPE,
    )
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 20)
    line = proc.stdout.readline().decode() if ready else ""
    if not line.startswith("listening on "):
        proc.kill()
        raise SystemExit(f"bus serve did not start: {line!r}")
    return proc, int(line.rsplit(":", 1)[1])


async def bench(port: int, ids: list[str], seconds: float, baud: int) -> None:
    byte_time = 10 / baud
    async with await BusMaster.open(f"tcp://127.0.0.1:{port}", baud=baud) as master:
        for mid in ids:
            await master.csservon(mid, "PC")
            await master.autoon(mid)
        polls = data_frames = failures = 0
        line_time = 0.0
        start = time.perf_counter()
        while time.perf_counter() - start < seconds:
            for mid in ids:
                request = encode_frame(mid, "PC", "REPLY")
                try:
                    data = await master.reply(mid)
                except Exception:
                    failures += 1
                    continue
                if data is None:
                    reply = encode_frame("PC", mid, "RREPLY.NODATA")
                else:
                    reply = encode_frame(data.addressee, mid, f"RPV.{data.value}")
                    data_frames += 1
                line_time += (len(request) + len(reply)) * byte_time + DEFAULT_TURNAROUND
                polls += 1
        elapsed = time.perf_counter() - start
        for mid in ids:
            await master.autooff(mid)

    achieved = polls / elapsed
    maximum = polls / line_time
    per_poll = line_time / polls
    print(f"bus: {len(ids)} modules at {baud} baud, turnaround {DEFAULT_TURNAROUND * 1e3:.1f} ms")
    print(f"polls: {polls} in {elapsed:.2f} s ({data_frames} data frames, {failures} failures)")
    print(f"line time per poll (frames + turnaround): {per_poll * 1e3:.2f} ms")
    print(f"theoretical maximum: {maximum:.2f} polls/s")
    print(f"achieved:            {achieved:.2f} polls/s")
    print(f"ratio:               {achieved / maximum * 100:.1f} % (target >= 90 %)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--modules", type=int, default=32)
    parser.add_argument("--baud", type=int, default=9600)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        site = Path(tmp) / "site.toml"
        site.write_text(site_text(args.modules, args.baud))
        proc, port = start_server(Path(tmp) / "state", site)
        try:
            ids = [f"N{i:02d}" for i in range(args.modules)]
            asyncio.run(bench(port, ids, args.seconds, args.baud))
        finally:
            proc.terminate()
            proc.wait(timeout=10)


if __name__ == "__main__":
    main()

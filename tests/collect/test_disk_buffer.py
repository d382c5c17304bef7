"""The collector's disk buffer: a durable FIFO per sink that survives ``kill -9``."""

from __future__ import annotations

import asyncio
import os
import signal
import subprocess
import sys
import textwrap
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from readings_gen import rows, text_row

from sondalog.collect.buffer import DiskBuffer, decode_batch, deliver, drain, encode_batch
from sondalog.collect.model import Reading, SinkUnavailable


def test_batch_round_trip_keeps_every_field() -> None:
    batch = [
        *rows("1001", 0, 3),
        text_row("1001", 5, "alarm: přetečení"),
        Reading(
            "bus:M1",
            2,
            datetime(2026, 5, 1, 12),
            4,
            2,
            -1.5e-3,
            None,
            "tlak",
            "hPa",
            datetime(2026, 5, 1, 10, tzinfo=UTC),
        ),
    ]
    assert decode_batch(encode_batch(batch)) == batch


def test_fifo_per_sink_and_ack(tmp_path: Path) -> None:
    buf = DiskBuffer(tmp_path / "b.sqlite")
    a1 = buf.append("postgres", rows("1", 0, 1))
    m1 = buf.append("mqtt", rows("1", 0, 1))
    a2 = buf.append("postgres", rows("1", 1, 2))
    assert [i for i, _ in buf.pending("postgres")] == [a1, a2]
    assert [i for i, _ in buf.pending("mqtt")] == [m1]
    buf.ack("postgres", a1)
    buf.ack("postgres", a1)  # twice: harmless
    buf.ack("mqtt", a2)  # another sink's id: not touched
    assert buf.pending("postgres") == [(a2, rows("1", 1, 2))]
    buf.close()
    again = DiskBuffer(tmp_path / "b.sqlite")
    assert again.count("postgres") == 1 and again.count("mqtt") == 1


class Flaky:
    """A sink that is down for the first ``down`` writes; keeps what it stored."""

    name = "flaky"

    def __init__(self, down: int) -> None:
        self.down = down
        self.stored: list[Reading] = []

    async def open(self) -> None:
        pass

    async def write(self, batch: Sequence[Reading]) -> None:
        if self.down > 0:
            self.down -= 1
            raise SinkUnavailable("down")
        self.stored.extend(batch)

    async def close(self) -> None:
        pass


def test_replay_keeps_order_and_stops_at_the_first_failure(tmp_path: Path) -> None:
    buf = DiskBuffer(tmp_path / "b.sqlite")
    sink = Flaky(down=3)
    batches = [rows("9", i, 1) for i in range(5)]

    async def run() -> None:
        assert not await deliver(buf, sink, batches[0])
        assert not await deliver(buf, sink, batches[1])
        assert not await deliver(buf, sink, batches[2])
        assert buf.count("flaky") == 3
        assert await deliver(buf, sink, batches[3])  # back: the queue is replayed first
        assert await deliver(buf, sink, batches[4])
        assert await drain(buf, sink) == 0

    asyncio.run(run())
    assert sink.stored == [r for b in batches for r in b]


WRITER = textwrap.dedent(
    """
    import sys
    from readings_gen import rows
    from sondalog.collect.buffer import DiskBuffer
    buf = DiskBuffer(sys.argv[1])
    i = 0
    while True:
        bid = buf.append("postgres", rows("K", i, 20))
        if i % 3 == 0:
            buf.ack("postgres", bid)
        print(bid, i, flush=True)
        i += 1
    """
)


def test_kill_9_loses_no_appended_batch(tmp_path: Path) -> None:
    path = tmp_path / "b.sqlite"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent)}
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True, env=env
    )
    assert proc.stdout is not None
    seen: list[tuple[int, int]] = []
    for line in proc.stdout:
        bid, i = map(int, line.split())
        seen.append((bid, i))
        if len(seen) == 200:
            os.kill(proc.pid, signal.SIGKILL)
            break
    proc.wait()
    buf = DiskBuffer(path)
    pending = buf.pending("postgres")
    ids = [bid for bid, _ in pending]
    assert ids == sorted(ids)
    held = dict(pending)
    for bid, i in seen:  # every append that returned is there, unless it was acked
        if i % 3:
            assert held[bid] == rows("K", i, 20)
        else:
            assert bid not in held

"""A fleet's loggers on one deadline loop (issue 24, io/timers.py): the due work of loggers
sampling on the same minute runs in slices, input is answered between them, and nothing a
logger answers or stores depends on the slicing or on how late its deadline ran."""

from __future__ import annotations

import asyncio
import math
import sqlite3
from collections.abc import Callable
from pathlib import Path

import pytest

from sondalog.ala1 import Engine, Identity
from sondalog.backends.sim.logger import SimHardware
from sondalog.backends.sim.signals import sine
from sondalog.backends.store.ala1_nv import NvDatabase
from sondalog.io import timers
from sondalog.io.clock import SteppedClock
from sondalog.io.host import DeviceHost, LocalLink
from sondalog.io.timers import Timers

T0 = 1_000_000_000.0
SETUP = (
    b"write channel max number 2 write output 1 value 1 write channel type 1 1 "
    b"write channel switch output 0 0\r",
    # every logger's clock on the same second: all sample at the same instants (§6.2)
    b"write channel sampling period 000010 000010 write date 20200101000000\r",
    b"write channel sampling start 20000101000000 20000101000000\r",
)
POLL = b"read channel sample write channel 1 name/x/ read record status\r"


async def _ask(link: LocalLink, line: bytes) -> bytes:
    link.write(line)
    answer = b""
    while not answer.endswith((b"OK\r\n", b"ERROR\r\n")):
        answer += await link.receive()
    return answer


Rows = list[tuple[str, int, str]]


class _Host(DeviceHost):
    """A host that counts the due work it ran and can send input when the flood starts."""

    def __init__(self, engine: Engine, fleet: Fleet) -> None:
        super().__init__(engine, fleet.clock, fleet.timers)
        self.fleet = fleet

    def run_due(self, now: float) -> None:
        self.fleet.ran += 1
        if self.fleet.on_first_run is not None:
            first, self.fleet.on_first_run = self.fleet.on_first_run, None
            first()
        super().run_due(now)


class Fleet:
    """``size`` loggers on one :class:`Timers`, each with a sine on its supply input, their
    memory in one database with group commit at the end of the loop's turn."""

    def __init__(self, tmp: Path, size: int, slice_seconds: float, pause: float = 0.0) -> None:
        self.clock = SteppedClock(T0)
        self.timers = Timers(self.clock, slice_seconds=slice_seconds, pause_seconds=pause)
        loop = asyncio.get_running_loop()
        self.database = NvDatabase(tmp / "fleet.sqlite", loop.call_soon)
        self.hosts: list[DeviceHost] = []
        self.links: list[LocalLink] = []
        self.ran = 0  # due work run by all hosts
        self.on_first_run: Callable[[], None] | None = None
        for n in range(size):
            serial = f"F{n:03}"
            supply = sine(12.0, 2.0 + n / 10, 37.0 + n, 0.0, T0)
            engine = Engine(
                Identity(serial_number=serial),
                self.database.store(serial),
                T0,
                SimHardware(supply=supply),
            )
            host = _Host(engine, self)
            host.start()
            self.hosts.append(host)
            self.links.append(host.link())

    async def setup(self) -> None:
        for link in self.links:
            for line in SETUP:
                assert (await _ask(link, line)).endswith(b"OK\r\n")

    def due(self) -> int:
        """Hosts whose deadline has come and not run yet."""
        now = self.clock.now()
        return sum(
            1
            for host in self.hosts
            if (deadline := self.timers.deadline(host)) is not None and deadline <= now
        )

    def rows(self) -> Rows:
        self.database.flush()
        reader = sqlite3.connect(self.database.path)
        try:
            return reader.execute("SELECT logger, seq, row FROM record ORDER BY 1, 2").fetchall()
        finally:
            reader.close()

    async def close(self) -> None:
        for link in self.links:
            await link.close()
        for host in self.hosts:
            await host.stop()
        self.database.close()


async def _scenario(
    tmp: Path, slice_seconds: float, pause: float = 0.0
) -> tuple[list[bytes], Rows]:
    """Steps of the clock that jump over sampling instants; after each, every logger is asked
    for its last samples while the fleet runs its due work (resting ``pause`` real seconds
    after each slice)."""
    fleet = Fleet(tmp, 12, slice_seconds, pause)
    answers: list[bytes] = []
    try:
        await fleet.setup()
        for step in (3.7, 8.1, 0.4, 12.6, 9.9, 10.0, 27.3, 0.2, 4.4):
            fleet.clock.advance(step)
            asked = [asyncio.ensure_future(_ask(link, POLL)) for link in fleet.links]
            answers += await asyncio.gather(*asked)
            for _ in range(20 if not pause else 400):  # let the deadline loop finish its work
                if not fleet.due():
                    break
                await asyncio.sleep(pause)
            assert fleet.due() == 0
        return answers, fleet.rows()
    finally:
        await fleet.close()


def test_answers_and_records_do_not_depend_on_slicing(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    whole = asyncio.run(_scenario(tmp_path / "a", math.inf))  # all due work in one go
    sliced = asyncio.run(_scenario(tmp_path / "b", 0.0))  # input between any two loggers
    assert sliced == whole
    answers, rows = whole
    assert len(answers) == 9 * 12 and all(a.endswith(b"OK\r\n") for a in answers)
    # 76.6 s of clock from 2020-01-01 00:00:00: instants 00, 10, ... 70 s, two channels
    assert len(rows) == 12 * 8
    stamps = sorted({row.split(",")[0] for _, _, row in rows})
    assert stamps == [f"2020010100{s // 60:02}{s % 60:02}.0" for s in range(0, 80, 10)]


def test_rests_between_slices_change_nothing_and_the_flood_ends(tmp_path: Path) -> None:
    """A fleet's loop rests after each slice (io/timers.py PAUSE): answers and rows are those
    of the whole flood at once, and every logger's due work is done (liveness)."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    whole = asyncio.run(_scenario(tmp_path / "a", math.inf))
    rested = asyncio.run(_scenario(tmp_path / "b", 0.0, pause=0.003))
    assert rested == whole


def test_a_long_flood_stops_resting(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Rests last for the first RESTS_FOR seconds of a flood only: due work that takes
    longer runs on at full speed (here rests of an hour, for no time at all)."""
    monkeypatch.setattr(timers, "RESTS_FOR", 0.0)

    async def run() -> int:
        fleet = Fleet(tmp_path, 20, 0.0, pause=3600.0)
        try:
            await fleet.setup()
            fleet.clock.advance(10.0)
            assert fleet.due() == 20
            for _ in range(100):
                await asyncio.sleep(0)
            return fleet.due()
        finally:
            await fleet.close()

    assert asyncio.run(asyncio.wait_for(run(), 60)) == 0


def test_a_sample_is_taken_at_its_deadline_however_late_it_runs(tmp_path: Path) -> None:
    """The clock jumps 9.5 s past an instant before the fleet runs: each row holds the
    signal at the instant's module time, not at the time the fleet got to it."""

    async def run() -> Rows:
        fleet = Fleet(tmp_path, 3, 0.0)
        try:
            await fleet.setup()
            start = fleet.rows()
            fleet.clock.advance(10.0 - 0.001 + 9.5)  # past the instant 10 s after the date
            for _ in range(20):
                await asyncio.sleep(0)
            return [row for row in fleet.rows() if row not in start]
        finally:
            await fleet.close()

    rows = asyncio.run(run())
    assert len(rows) == 3
    for logger, _, row in rows:
        n = int(logger[1:])
        stamp, kind, first, second = row.split(",")
        assert stamp == "20200101000010.0" and kind == "1" and first == second
        # the date was written at the clock's T0: 10 s later is T0 + 10 on the host clock
        expected = sine(12.0, 2.0 + n / 10, 37.0 + n, 0.0, T0)(T0 + 10.0)
        assert abs(float(first) - expected) <= 0.051  # one decimal (format 4.1)


def test_input_is_answered_while_a_flood_of_deadlines_runs(tmp_path: Path) -> None:
    """Every logger is due at once; a request that arrives as the first of them samples is
    answered after a slice, while the others have not sampled yet; its logger samples up to
    its now before it answers, so the answer holds the new sample."""

    async def run(slice_seconds: float) -> tuple[list[int], int, bytes]:
        fleet = Fleet(tmp_path / str(slice_seconds), 60, slice_seconds)
        try:
            await fleet.setup()
            before = await _ask(fleet.links[-1], b"read channel 1 sample\r")
            answered: list[int] = []  # due work run when each answer left
            link = fleet.hosts[-1].link(lambda data: answered.append(fleet.ran))
            fleet.on_first_run = lambda: link.write(b"read channel 1 sample\r")
            fleet.ran = 0
            fleet.clock.advance(10.0)
            assert fleet.due() == 60
            for _ in range(200):
                await asyncio.sleep(0)
            assert fleet.due() == 0
            after = await _ask(fleet.links[-1], b"read channel 1 sample\r")
            assert after != before
            return answered, fleet.ran, after
        finally:
            await fleet.close()

    for folder in ("0.0", "inf"):
        (tmp_path / folder).mkdir()
    sliced, ran, answer = asyncio.run(run(0.0))
    assert sliced == [1]  # answered right after the first logger's slice
    assert ran == 59  # the logger asked had sampled when it answered: its deadline moved
    whole, ran, whole_answer = asyncio.run(run(math.inf))
    assert whole == [60] and ran == 60  # without slices the request waits for the flood
    assert answer == whole_answer

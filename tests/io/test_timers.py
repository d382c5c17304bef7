"""The one deadline loop (issue 24, io/timers.py): every host runs at each deadline it was
given, never before it, earliest first, and a flood of due hosts yields to the loop after
every slice."""

from __future__ import annotations

import asyncio

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.io.clock import SteppedClock
from sondalog.io.timers import Timers

T0 = 1000.0


class _Host:
    """A device whose deadlines are a list; it records when it ran."""

    def __init__(self, timers: Timers, clock: SteppedClock, deadlines: list[float]) -> None:
        self.timers = timers
        self.clock = clock
        self.deadlines = sorted(deadlines)
        self.ran: list[tuple[float, float]] = []  # (deadline, now)

    def next(self) -> float | None:
        return self.deadlines[0] if self.deadlines else None

    def run_due(self, now: float) -> None:
        deadline = self.deadlines.pop(0)
        self.ran.append((deadline, now))
        self.timers.set(self, self.next())


@settings(max_examples=60, deadline=None)
@given(
    plans=st.lists(
        st.lists(st.integers(0, 40).map(lambda s: T0 + s / 2), max_size=6), min_size=1, max_size=8
    ),
    steps=st.lists(st.integers(1, 15).map(lambda s: s / 2), min_size=1, max_size=12),
    moved=st.lists(st.tuples(st.integers(0, 7), st.integers(0, 40)), max_size=5),
)
def test_every_deadline_runs_once_never_early_in_order(
    plans: list[list[float]], steps: list[float], moved: list[tuple[int, int]]
) -> None:
    async def run() -> tuple[list[_Host], list[float]]:
        clock = SteppedClock(T0)
        timers = Timers(clock, slice_seconds=0.0)
        hosts = [_Host(timers, clock, plan) for plan in plans]
        order: list[float] = []  # deadlines in the order they ran
        for host in hosts:
            timers.add(host, host.next())
        for index, (which, at) in enumerate(moved):  # input moves some deadlines
            host = hosts[which % len(hosts)]
            host.deadlines = sorted([*host.deadlines, T0 + at / 2 + index / 100])
            timers.set(host, host.next())
        for step in steps:
            clock.advance(step)
            for _ in range(200):
                await asyncio.sleep(0)
        for host in hosts:
            order += [deadline for deadline, _ in host.ran]
            await timers.remove(host)
        return hosts, order

    hosts, _ = asyncio.run(run())
    end = T0 + sum(steps)
    for host in hosts:
        assert all(now >= deadline for deadline, now in host.ran)  # never early
        assert all(deadline > end for deadline in host.deadlines)  # none left behind
        assert [d for d, _ in host.ran] == sorted(d for d, _ in host.ran)


def test_a_flood_yields_to_the_loop_after_every_slice() -> None:
    """600 hosts due at once, each at least 1 ms of work, slices of 5 ms: a callback
    scheduled when the flood starts runs after the first slice (at most 5 hosts), and the
    loop turned at least once every 5 hosts."""

    async def run() -> tuple[int, int]:
        clock = SteppedClock(T0)
        timers = Timers(clock, slice_seconds=0.005)
        ran = 0
        seen: list[int] = []

        class Busy:
            def run_due(self, now: float) -> None:
                nonlocal ran
                if ran == 0:
                    asyncio.get_running_loop().call_soon(lambda: seen.append(ran))
                ran += 1
                began = asyncio.get_running_loop().time()
                while asyncio.get_running_loop().time() - began < 0.001:
                    pass

        hosts = [Busy() for _ in range(600)]
        for host in hosts:
            timers.add(host, T0 + 1)
        clock.advance(1)
        while ran < 600:
            await asyncio.sleep(0)
        for host in hosts:
            await timers.remove(host)
        return seen[0], timers.slices

    first, slices = asyncio.run(run())
    assert first <= 5  # after one slice, not after all 600
    assert 119 <= slices <= 600

"""The contacts start on a shared grid of loop time (issue 24, ``sondalog.collect.ticks``):
sources with random offsets, intervals, contact durations and failures, on a virtual clock,
start every contact after their first on an instant of their grid; a source's contacts stay
``interval`` apart within one step, never early, the lateness not adding up; none starved."""

from __future__ import annotations

import asyncio
import itertools
import math
import random
import selectors
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.collect.config import CollectorConfig, SourceConfig
from sondalog.collect.delivery import Deliver
from sondalog.collect.runner import Collector
from sondalog.collect.ticks import TICK, Ticks, grid_instant, next_due, step_for


class _Selector(selectors.DefaultSelector):
    """No real waiting: a select that would wait moves the virtual clock on instead."""

    def __init__(self) -> None:
        super().__init__()
        self.now = 1000.0

    def select(self, timeout: float | None = None) -> list[Any]:
        events: list[Any] = super().select(0)
        if not events and timeout is not None and timeout > 0:
            self.now += timeout
        return events


class _VirtualLoop(asyncio.SelectorEventLoop):
    def __init__(self) -> None:
        self._virtual = _Selector()
        super().__init__(self._virtual)

    def time(self) -> float:
        return self._virtual.now


class _Random:
    """A source whose contacts take a random time (a sleep) and fail now and then; it
    records each contact's start, end and outcome in loop time."""

    kind = "logger"

    def __init__(self, config: SourceConfig, rng: random.Random, longest: float, fails: float):
        self.config = config
        self.rng = rng
        self.longest = longest
        self.fails = fails
        self.contacts: list[tuple[float, float, bool]] = []

    async def poll(self, deliver: Deliver) -> str:
        loop = asyncio.get_running_loop()
        start = loop.time()
        await asyncio.sleep(self.rng.uniform(0, self.longest))
        ok = self.rng.random() >= self.fails
        self.contacts.append((start, loop.time(), ok))
        if not ok:
            raise OSError("no answer")
        await deliver(self.config.name, [], None)
        return "done"


def _on_grid(instant: float, step: float) -> bool:
    return step > 0 and abs(instant / step - round(instant / step)) < 1e-6


def _run(seed: int, count: int, intervals: list[float], longest: float, fails: float) -> Any:
    """``count`` sources (intervals drawn from ``intervals``, first contacts at random
    offsets within the shortest interval) for 10 of the longest intervals of virtual time."""
    rng = random.Random(seed)
    configs = tuple(
        SourceConfig(
            f"s{n}",
            "tcp://127.0.0.1:9",
            interval=rng.choice(intervals),
            retry=rng.choice([0.2, 1.0, 5.0]),
            retry_max=30,
            config_every=0,
        )
        for n in range(count)
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp)
        config = CollectorConfig(
            path / "c.toml", path / "s.sqlite", True, path / "b.sqlite", configs, {}
        )
        collector = Collector(config)
        collector.open()
        sources = [
            _Random(cfg, random.Random(rng.random()), longest * cfg.interval, fails)
            for cfg in configs
        ]
        span = 10 * max(intervals)

        async def main() -> float:
            loop = asyncio.get_running_loop()
            began = loop.time()
            tasks = [
                asyncio.create_task(collector._loop(s, rng.uniform(0, min(intervals)), False))
                for s in sources
            ]
            await asyncio.sleep(span)
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            return began

        loop = _VirtualLoop()
        try:
            began = loop.run_until_complete(main())
        finally:
            loop.close()
            collector.store.close_sync()
    return sources, began, span


@settings(max_examples=30)
@given(
    seed=st.integers(0, 2**32),
    count=st.integers(1, 25),
    intervals=st.lists(st.sampled_from([0.5, 1.0, 7.25, 10.0, 60.0]), min_size=1, max_size=3),
    longest=st.sampled_from([0.0, 0.01, 0.3, 1.5]),
    fails=st.sampled_from([0.0, 0.2]),
)
def test_contacts_start_on_the_grid_interval_apart_none_starved(
    seed: int, count: int, intervals: list[float], longest: float, fails: float
) -> None:
    sources, began, span = _run(seed, count, intervals, longest, fails)
    for source in sources:
        cfg = source.config
        contacts = source.contacts
        assert contacts, "starved: never contacted"
        failures = 0
        for (start, end, ok), (after, _, _) in itertools.pairwise(contacts):
            failures = 0 if ok else failures + 1
            wait = cfg.interval if ok else min(cfg.retry * 2 ** (failures - 1), cfg.retry_max)
            step = step_for(wait)
            # on its grid: the sources due within a step start together
            assert _on_grid(after, step), (after, step)
            if ok:  # start to start: never a step early, at most a step late or after the
                # contact
                assert after >= start + cfg.interval - step - 1e-6
                assert after <= max(start + cfg.interval, end) + step + 1e-6
            else:  # the backoff from the failure's end, at most a step late
                assert end + wait - 1e-6 <= after <= end + wait + step + 1e-6
        # the lateness does not add up: a source that never fails and is quick keeps its
        # rate (one contact an interval from its first, within one step)
        if all(ok for *_, ok in contacts) and source.longest < cfg.interval:
            first = contacts[0][0]
            expected = math.floor((began + span - first - TICK) / cfg.interval)
            assert len(contacts) >= expected, (len(contacts), expected)
        # none starved: the last contact is at most an interval (or the longest backoff)
        # plus the contact plus a step before the end
        worst = max(cfg.interval, cfg.retry_max) * 2 + source.longest + TICK
        assert contacts[-1][0] >= began + span - worst


def test_sources_of_one_interval_start_together() -> None:
    """A hundred sources every 60 s at random offsets: at most one start instant a second
    (one wake of the loop for the contacts due within it), not a hundred a minute."""
    sources, _, span = _run(7, 100, [60.0], 0.0, 0.0)
    later = {start for s in sources for start, _, _ in s.contacts[1:]}
    assert all(_on_grid(t, TICK) for t in later)
    assert len(later) <= span / TICK
    assert sum(len(s.contacts) - 1 for s in sources) > 1.5 * len(later)  # ~2: 100 in 60 s


@given(wait=st.floats(0, 1e6, allow_nan=False), due=st.floats(-1e6, 1e9, allow_nan=False))
def test_the_step_is_a_tenth_of_the_wait_at_most_and_the_instant_at_most_a_step_late(
    wait: float, due: float
) -> None:
    step = step_for(wait)
    assert step <= max(0.0, wait / 10)
    if step:
        assert step == TICK or step > wait / 20  # the largest that fits
        assert math.log2(TICK / step).is_integer()  # finer grids hold the coarser's instants
    instant = grid_instant(due, step)
    assert due - 1e-9 * max(1.0, abs(due)) <= instant <= due + step + 1e-9 * max(1.0, abs(due))


@given(
    due=st.floats(0, 1e6),
    late=st.floats(0, 1e3),
    took=st.floats(0, 1e4),
    wait=st.floats(0, 1e4),
    ok=st.booleans(),
)
def test_next_due(due: float, late: float, took: float, wait: float, ok: bool) -> None:
    """Never before the contact's end; after a contact that went well, never more than a step
    early against its start, and on schedule (its due instant's successor) unless it started
    late by more than a step or ended after it."""
    started = due + late
    now = started + took
    after = next_due(due, started, now, wait, ok)
    assert after >= now
    if not ok:
        assert after == now + wait
        return
    step = step_for(wait)
    assert after >= started + wait - step
    assert after >= due + wait
    if late <= step and now <= due + wait:
        assert after == due + wait  # on schedule: the lateness does not add up


def test_a_cancelled_waiter_leaves_the_others_waiting() -> None:
    ticks = Ticks()

    async def main() -> list[bool]:
        loop = asyncio.get_running_loop()
        at = loop.time() + 0.5
        first, second = ticks.until(at), ticks.until(at)
        assert len(ticks) == 1  # one timer for both
        first.cancel()
        await second
        ticks.until(at + 5)  # left waiting when this loop closes
        return [first.cancelled(), second.done(), len(ticks) == 1]

    for _ in range(2):  # the same instants on another loop: timers of its own, not the last's
        loop = _VirtualLoop()
        try:
            assert loop.run_until_complete(asyncio.wait_for(main(), 10)) == [True, True, True]
        finally:
            loop.close()

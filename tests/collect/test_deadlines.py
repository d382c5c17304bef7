"""The loop's deadlines in one heap (:mod:`sondalog.client.deadlines`, issue 24): on a stepped
clock, every deadline not cancelled fires once, never early and at most a grain late (plus
the clock's step), a cancelled one never; nothing is left stuck, and the loop's timer is
armed exactly while something waits. Then on a real loop: sleeps and a callback that raises."""

from __future__ import annotations

import asyncio
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.client.deadlines import GRAIN, Deadlines, deadlines


class _Timer:
    def __init__(self, when: float, callback: Any) -> None:
        self.when, self.callback = when, callback
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class _SteppedLoop:
    """The part of a loop :class:`Deadlines` uses, on a clock the test steps."""

    def __init__(self) -> None:
        self.now = 0.0
        self.timers: list[_Timer] = []

    def time(self) -> float:
        return self.now

    def call_at(self, when: float, callback: Any) -> _Timer:
        timer = _Timer(when, callback)
        self.timers.append(timer)
        return timer

    def step(self, seconds: float) -> None:
        """The clock runs ``seconds``; each timer due runs at its time (as a loop would)."""
        end = self.now + seconds
        while True:
            due = [t for t in self.timers if not t.cancelled and t.when <= end]
            if not due:
                break
            timer = min(due, key=lambda t: t.when)
            self.timers.remove(timer)
            self.now = max(self.now, timer.when)
            timer.callback()
        self.now = end

    def armed(self) -> list[_Timer]:
        return [t for t in self.timers if not t.cancelled]


OPS = st.lists(
    st.one_of(
        st.tuples(st.just("add"), st.floats(0, 20)),
        st.tuples(st.just("cancel"), st.integers(0, 50)),
        st.tuples(st.just("step"), st.floats(0, 3)),
    ),
    max_size=60,
)


@settings(max_examples=200, deadline=None)
@given(ops=OPS)
def test_every_live_deadline_fires_once_on_time_and_nothing_is_stuck(ops: list[Any]) -> None:
    loop = _SteppedLoop()
    timers = Deadlines(loop)  # type: ignore[arg-type]
    entries: list[Any] = []
    wanted: dict[int, float] = {}  # live deadline -> when
    fired: dict[int, float] = {}

    def fire(n: int) -> None:
        assert n not in fired
        fired[n] = loop.now

    for op, value in ops:
        if op == "add":
            n = len(entries)
            entries.append(timers.call_at(loop.now + value, fire, n))
            wanted[n] = loop.now + value
        elif op == "cancel" and entries:
            n = value % len(entries)
            if n not in fired:
                timers.cancel(entries[n])
                wanted.pop(n, None)
        elif op == "step":
            loop.step(value)
        assert len(loop.armed()) <= 1
        waiting = [when for n, when in wanted.items() if n not in fired]
        if waiting:  # armed by the earliest (a cancelled one may wake it sooner), a grain late
            (timer,) = loop.armed()
            assert timer.when <= max(min(waiting), loop.now) + GRAIN + 1e-9
    loop.step(25.0 + GRAIN)  # past every deadline
    assert set(fired) == set(wanted)
    for n, at in fired.items():
        assert wanted[n] <= at <= wanted[n] + GRAIN + 1e-9  # never early, at most a grain late
    assert not loop.armed() and len(timers) == 0


def test_sleeps_and_a_raising_callback_on_a_real_loop() -> None:
    async def main() -> list[str]:
        timers = deadlines()
        assert deadlines() is timers  # one per loop
        order: list[str] = []
        loop = asyncio.get_running_loop()

        def boom(_: Any) -> None:
            raise RuntimeError("boom")

        loop.set_exception_handler(lambda _loop, ctx: order.append("reported"))
        timers.call_later(0.01, boom)
        start = loop.time()

        async def sleeper(name: str, seconds: float) -> None:
            await timers.sleep(seconds)
            assert loop.time() - start >= seconds
            order.append(name)

        cancelled = asyncio.create_task(sleeper("never", 0.02))
        await asyncio.sleep(0)
        cancelled.cancel()
        await asyncio.gather(sleeper("b", 0.05), sleeper("a", 0.03), timers.sleep(0))
        assert cancelled.cancelled()
        return order

    assert asyncio.run(main()) == ["reported", "a", "b"]

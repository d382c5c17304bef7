"""Many deadlines of one event loop on one timer of it (issue 24).

A collector of ten thousand sources waits at every contact: for the next contact (a sleep of
about the interval) and for each answer (its timeout, almost always cancelled when the bytes
come a few milliseconds later). A timer of the loop each (``call_later``: on uvloop a timer
handle of libuv, made, started, stopped and closed) costs more than the wait itself is worth.
:class:`Deadlines` keeps them in a heap of its own, with one loop timer for the earliest
live one; a cancelled deadline is only marked, and dropped when the heap comes to it.

The timer runs at most every :data:`GRAIN` seconds: a deadline fires at its time or up to
that much later, never earlier (a sleep of the collector's interval, an answer's timeout of
seconds). :func:`deadlines` is the one of the running loop.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import math
import weakref
from collections.abc import Callable
from typing import Any

#: Seconds a deadline may fire late (deadlines that fall within it share the timer's run).
GRAIN = 0.005

#: A deadline: ``[when, order, callback or None (cancelled), argument]``.
Entry = list[Any]


class Deadlines:
    """The deadlines of one loop (see the module docstring)."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = weakref.proxy(loop)  # the loop's entry in _OF must not keep it alive
        self._heap: list[Entry] = []
        self._order = itertools.count()
        self._timer: asyncio.TimerHandle | None = None
        self._armed = math.inf  # when the timer runs
        self._ran = -math.inf  # when it last ran

    def __len__(self) -> int:
        """Deadlines in the heap, cancelled ones not dropped yet included (tests)."""
        return len(self._heap)

    def call_at(self, when: float, callback: Callable[[Any], object], arg: Any = None) -> Entry:
        """Call ``callback(arg)`` at loop time ``when`` (or up to :data:`GRAIN` later)."""
        entry = [when, next(self._order), callback, arg]
        heapq.heappush(self._heap, entry)
        if when < self._armed:
            self._arm(when)
        return entry

    def call_later(self, delay: float, callback: Callable[[Any], object], arg: Any = None) -> Entry:
        return self.call_at(self._loop.time() + delay, callback, arg)

    @staticmethod
    def cancel(entry: Entry) -> None:
        """The deadline will not fire (dropped from the heap when its time comes)."""
        entry[2] = entry[3] = None

    async def sleep(self, delay: float) -> None:
        """``asyncio.sleep(delay)`` on this heap (a bare future, no timer of its own); 0 or
        less only yields, as ``asyncio.sleep(0)``."""
        if delay <= 0:
            await asyncio.sleep(0)
            return
        future: asyncio.Future[None] = self._loop.create_future()
        entry = self.call_later(delay, _wake, future)
        try:
            await future
        finally:
            self.cancel(entry)

    def _arm(self, when: float) -> None:
        when = max(when, self._ran + GRAIN)
        if self._timer is not None:
            if when >= self._armed:
                return
            self._timer.cancel()
        self._armed = when
        self._timer = self._loop.call_at(when, self._run)

    def _run(self) -> None:
        self._timer, self._armed = None, math.inf
        now = self._ran = self._loop.time()
        heap = self._heap
        try:
            while heap and (heap[0][0] <= now or heap[0][2] is None):
                _, _, callback, arg = heapq.heappop(heap)
                if callback is not None:
                    callback(arg)
        finally:  # a callback that raised (the loop reports it) leaves the others due
            if heap:
                self._arm(heap[0][0])


def _wake(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


_OF: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, Deadlines] = weakref.WeakKeyDictionary()


def deadlines() -> Deadlines:
    """The :class:`Deadlines` of the running loop."""
    loop = asyncio.get_running_loop()
    found = _OF.get(loop)
    if found is None:
        found = _OF[loop] = Deadlines(loop)
    return found

"""One deadline loop for many device hosts, its due work run in slices (issue 24).

Every :class:`~sondalog.io.host.DeviceHost` has its deadline (its device's
``next_deadline``) in a :class:`Timers`: one task sleeps until the earliest and then runs
every host that is due, earliest first. A single logger, a bus or the GSM network has Timers
of its own; a fleet's loggers share one, so ten thousand loggers cost one task, not ten
thousand sleeping ones.

When many hosts are due at once (a fleet whose loggers sample on the same minute), the work
is cut into slices of at most :data:`SLICE` seconds: between two slices the loop yields, so
input is read and answered while the rest of the due work waits for the next slice, as a
real logger answers while it samples. A fleet's loop also rests between slices
(:data:`PAUSE`, for the first :data:`RESTS_FOR` seconds of a flood): the flood takes longer,
but a process that leaves the processor now and then is scheduled at once when input comes
on a busy machine (issue 24: answers of 75 ms in a sampling second without rests).

Running a host late changes nothing it stores or answers: a device timestamps what falls
due with the time of its deadline (the ALA1 samples at its scheduled module second, whatever
the clock says when it runs), and input on a host that waits for its slice runs that host's
due work first (the ALA1's ``receive`` samples up to its ``now`` before it answers).
"""

from __future__ import annotations

import asyncio
import contextlib
import heapq
import itertools
import time
from typing import Protocol

from sondalog.io.clock import Clock

#: The most seconds of due work run before the loop serves input again.
SLICE = 0.002
#: Seconds a fleet's loop rests after each slice of a flood (``pause_seconds``): the process
#: gives the processor away, so on a machine shared with other work the system schedules it
#: again at once when input comes, instead of making it wait for the time it took.
PAUSE = 0.002
#: A flood that has run this many seconds runs on without rests (the due work keeps up).
RESTS_FOR = 5.0


class Due(Protocol):
    """What the timers run: a host whose deadline came."""

    def run_due(self, now: float) -> None:
        """Run the device's due work at clock time ``now`` (and set the next deadline)."""
        ...


class Timers:
    """The deadlines of some hosts on one clock, and the one task that runs them."""

    def __init__(
        self, clock: Clock, *, slice_seconds: float = SLICE, pause_seconds: float = 0.0
    ) -> None:
        """``pause_seconds``: the rest after each slice of a flood (:data:`PAUSE` for a
        fleet; 0: the loop only yields to input, as a single logger's does)."""
        self.clock = clock
        self.slice = slice_seconds
        self.pause = pause_seconds
        self._deadlines: dict[Due, float] = {}  # host -> its deadline (live heap entry)
        self._heap: list[tuple[float, int, Due]] = []  # entries stale once replaced
        self._order = itertools.count()  # equal deadlines run in the order they were set
        self._members: set[Due] = set()
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self.slices = 0  # slices after which the loop yielded to input (benchmarks, tests)

    # -- membership --------------------------------------------------------------------------
    def add(self, host: Due, deadline: float | None) -> None:
        """Run ``host`` at its deadlines from now on (starts the task: needs a running loop)."""
        self._members.add(host)
        self.set(host, deadline)
        if self._task is None:
            self._task = asyncio.get_running_loop().create_task(self._run())

    async def remove(self, host: Due) -> None:
        """``host`` runs no more; the task ends with the last host."""
        self._members.discard(host)
        self._deadlines.pop(host, None)
        if not self._members and self._task is not None:
            task, self._task = self._task, None
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            self._heap.clear()

    def set(self, host: Due, deadline: float | None) -> None:
        """``host``'s next deadline is ``deadline`` (None: it waits for input)."""
        if host not in self._members or self._deadlines.get(host) == deadline:
            return
        if deadline is None:
            del self._deadlines[host]
            return
        self._deadlines[host] = deadline
        heap = self._heap
        if len(heap) > 2 * len(self._deadlines) + 64:  # too many stale entries: rebuild
            live = self._deadlines
            heap[:] = [entry for entry in heap if live.get(entry[2]) == entry[0]]
            heapq.heapify(heap)
        first = heap[0][0] if heap else None
        heapq.heappush(heap, (deadline, next(self._order), host))
        if first is None or deadline < first:
            self._wake.set()

    def wake(self) -> None:
        """Look at the earliest deadline again now (a clock that jumped, a device replaced)."""
        self._wake.set()

    def deadline(self, host: Due) -> float | None:
        """The deadline ``host`` is armed for."""
        return self._deadlines.get(host)

    # -- the task ----------------------------------------------------------------------------
    def _earliest(self) -> float | None:
        heap, live = self._heap, self._deadlines
        while heap:
            deadline, _, host = heap[0]
            if live.get(host) == deadline:
                return deadline
            heapq.heappop(heap)  # stale: the host's deadline moved since
        return None

    async def _run(self) -> None:
        while True:
            self._wake.clear()
            deadline = self._earliest()
            if deadline is None:
                await self._wake.wait()
            elif self.clock.now() < deadline:
                await self._sleep_or_wake(deadline)
            else:
                await self.run_due()

    async def run_due(self) -> None:
        """Run every host due now, earliest first, yielding to input after each slice."""
        heap, live = self._heap, self._deadlines
        now = self.clock.now()
        began = flood = time.perf_counter()
        while heap and heap[0][0] <= now:
            deadline, _, host = heapq.heappop(heap)
            if live.get(host) != deadline:
                continue
            del live[host]  # it sets its next deadline while it runs
            host.run_due(now)
            if (ended := time.perf_counter()) - began >= self.slice:
                self.slices += 1
                rest = self.pause if ended - flood < RESTS_FOR else 0.0
                await asyncio.sleep(rest)  # input and its answers go first
                now = self.clock.now()
                began = time.perf_counter()

    async def _sleep_or_wake(self, deadline: float) -> None:
        sleeper = asyncio.ensure_future(self.clock.sleep_until(deadline))
        waker = asyncio.ensure_future(self._wake.wait())
        try:
            await asyncio.wait({sleeper, waker}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in (sleeper, waker):
                task.cancel()
            await asyncio.gather(sleeper, waker, return_exceptions=True)

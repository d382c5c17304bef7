"""The collector's contacts start on a shared grid of loop time (issue 24, seventh round).

Each source used to sleep to its own instant: ten thousand sources every minute were 167
distinct timer wakes of the loop a second, and each wake then carried one contact's connect,
write, answer and close through wakes of their own. A contact's CPU was mostly the loop's
waking up (epoll, the loop's iteration, the callbacks), measured 1.2-1.4 ms a contact on a
quiet machine and half that on a busy one, where one wake found several contacts' events.

Here a source's next contact waits for the first instant of a grid at or after the instant it
is due: the sources due within one step start together, in one wake, and their connects,
answers and closes share wakes too. The step (:func:`step_for`) is at most :data:`TICK` and
at most a tenth of the wait, halved from :data:`TICK` until it fits (1, 0.5, 0.25 ... s:
every finer grid holds the coarser ones' instants, so sources of different intervals meet
too); a contact starts at most one step (a tenth of its wait) late, never early, and the
lateness does not add up: the next contact is due ``interval`` after the instant this one was
due, not after it started, but never more than a step before ``interval`` after it started
(:func:`next_due`).

:func:`grid_instant`, :func:`step_for` and :func:`next_due` are pure; :class:`Ticks` holds one
timer a grid instant for every source waiting for it.
"""

from __future__ import annotations

import asyncio
import math

#: The coarsest step of the grid (s): chosen by measurement (benchmarks/README.md, seventh
#: round): ten thousand sources every minute are 167 contacts a step.
TICK = 1.0
#: A step is at most this share of the wait it ends (a 0.5 s interval: steps of 1/32 s).
SHARE = 0.1
#: Below this step a wait is not rounded (a wait of 10 ms or less: at once, as it was).
FINEST = 2.0**-10


def step_for(wait: float) -> float:
    """The grid step for a wait of ``wait`` seconds: the largest of TICK, TICK/2, TICK/4 ...
    not above ``SHARE * wait``; 0.0 (no grid) when that is below :data:`FINEST`."""
    limit = SHARE * wait
    if not limit >= FINEST:  # also NaN
        return 0.0
    if limit >= TICK:
        return TICK
    return TICK * 2.0 ** math.floor(math.log2(limit / TICK))


def grid_instant(due: float, step: float) -> float:
    """The first instant of the grid of ``step`` at or after ``due`` (``due`` itself when
    ``step`` is 0). A due instant on the grid but for the rounding of its sum is taken as on
    it (a nanosecond's tolerance), not a step later."""
    if step <= 0.0:
        return due
    return math.ceil(due / step - 1e-9) * step


def next_due(due: float, started: float, now: float, wait: float, ok: bool) -> float:
    """When the next contact is due, after one that was ``due``, ``started`` and ended at
    ``now``. After a contact that went well: ``wait`` (the interval) after the instant it was
    due, so the grid's lateness does not add up; but at most a step of the grid earlier than
    ``wait`` after it started (a contact the loop started late, busy, is not followed by
    one early: the schedule slips, as it did before the grid), and not before ``now`` (a
    contact that took longer than its interval: the next at once, as before). After a
    failure: ``wait`` after ``now`` (the retry's backoff counts from the failure)."""
    if not ok:
        return now + wait
    return max(due + wait, started + wait - step_for(wait), now)


class Ticks:
    """Waits for grid instants of one loop: one timer an instant, shared by every waiter.

    Each waiter has its own future (a cancelled waiter cancels only its own); the timer of an
    instant sets them all in one callback, so their tasks run in the same loop iteration.
    """

    def __init__(self) -> None:
        self._waiting: dict[float, list[asyncio.Future[None]]] = {}
        self._loop: asyncio.AbstractEventLoop | None = None

    def __len__(self) -> int:
        """Instants with a timer set (for tests)."""
        return len(self._waiting)

    def until(self, instant: float) -> asyncio.Future[None]:
        """A future set at loop time ``instant`` (at the next iteration when it is past)."""
        loop = asyncio.get_running_loop()
        if loop is not self._loop:  # another run (asyncio.run again): its timers are gone
            self._waiting.clear()
            self._loop = loop
        future: asyncio.Future[None] = loop.create_future()
        waiters = self._waiting.get(instant)
        if waiters is None:
            waiters = self._waiting[instant] = []
            loop.call_at(instant, self._fire, instant)
        waiters.append(future)
        return future

    def _fire(self, instant: float) -> None:
        for future in self._waiting.pop(instant, ()):
            if not future.done():
                future.set_result(None)

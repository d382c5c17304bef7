"""A clock the control API drives (issue 23): pause, resume, a new speed, a step.

:class:`ControlledClock` is the clock of ``sondalog serve --control``. It runs like
:class:`~sondalog.io.clock.AcceleratedClock` (``--speed``, 1: real time) until told
otherwise: :meth:`pause` stops it, :meth:`resume` lets it run again from where it stopped,
:meth:`set_rate` changes how fast it runs from now on, :meth:`step` moves it forward at once
(paused, it moves only by steps: the stepped clock of a test, over the network). Every change
wakes whoever sleeps in :meth:`sleep_until`, so a device host runs at once what a step made
due.

:attr:`speed` stays the speed given at start: it is the scale of line time the engines were
built with (docs/decisions.md "Time base"); :attr:`rate` is how fast the clock runs now.
"""

from __future__ import annotations

import asyncio
import contextlib
import time


class ControlledClock:
    """Clock seconds that run at :attr:`rate` times real time, pause and step on demand."""

    def __init__(
        self, speed: float = 1.0, start: float | None = None, *, paused: bool = False
    ) -> None:
        if not speed > 0:
            raise ValueError("speed must be positive")
        self.speed = speed
        self.rate = speed
        self.paused = paused
        self._base = time.time() if start is None else start  # clock seconds at the anchor
        self._anchor = time.monotonic()
        self._changed = asyncio.Event()

    def now(self) -> float:
        if self.paused:
            return self._base
        return self._base + (time.monotonic() - self._anchor) * self.rate

    def _rebase(self, base: float) -> None:
        self._base = base
        self._anchor = time.monotonic()
        changed, self._changed = self._changed, asyncio.Event()
        changed.set()  # every sleeper looks at the clock again

    def pause(self) -> float:
        """Stop the clock; returns the time it stopped at."""
        now = self.now()
        self.paused = True
        self._rebase(now)
        return now

    def resume(self) -> float:
        """Let the clock run again from where it stopped."""
        now = self.now()
        self.paused = False
        self._rebase(now)
        return now

    def set_rate(self, rate: float) -> float:
        """Run ``rate`` times real time from now on (paused, it stays paused)."""
        if not rate > 0:
            raise ValueError("the rate must be positive")
        now = self.now()
        self.rate = rate
        self._rebase(now)
        return now

    def step(self, seconds: float) -> float:
        """Move the clock forward by ``seconds`` now; returns the new time."""
        if seconds < 0:
            raise ValueError("a clock does not run backwards")
        now = self.now() + seconds
        self._rebase(now)
        return now

    def advance_to(self, moment: float) -> float:
        """Move the clock forward to exactly ``moment`` (if it is not there yet); the new time."""
        now = self.now()
        if moment > now:
            self._rebase(moment)
            return moment
        return now

    async def sleep_until(self, deadline: float) -> None:
        while True:
            now = self.now()
            if now >= deadline:
                return
            changed = self._changed
            delay = None if self.paused else (deadline - now) / self.rate
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(changed.wait(), delay)

"""One clock abstraction for every device (DESIGN.md point 2).

Cores never read the wall clock: transports ask a :class:`Clock` for ``now()`` (seconds, float)
and hand that value to the core, and they sleep until the core's next deadline with
:meth:`Clock.sleep_until`. Three clocks exist:

- :class:`RealClock`: wall-clock seconds since the epoch (``--speed 1``).
- :class:`AcceleratedClock`: starts at the wall clock and runs ``speed`` times faster, so a
  year of module time passes in minutes. Time that passes while the process is stopped is
  counted at 1x when the next process starts (the module's battery-backed clock kept going).
- :class:`SteppedClock`: only moves when a test calls :meth:`SteppedClock.advance`.
- :class:`LoopClock`: follows the event loop's own time (virtual time in tests).
"""

from __future__ import annotations

import asyncio
import time
from typing import Protocol


class Clock(Protocol):
    """What transports need from a clock."""

    @property
    def speed(self) -> float:
        """How many clock seconds pass in one real second (``--speed``; 1 for the others).

        Device work (sampling, the module clock) follows the clock; what happens on a line
        (pacing, timeouts, XMODEM) follows real time, that is clock time divided by this."""
        ...

    def now(self) -> float:
        """Current clock time in seconds."""
        ...

    async def sleep_until(self, deadline: float) -> None:
        """Return once ``now() >= deadline`` (or earlier; callers re-check)."""
        ...


class RealClock:
    """Wall-clock time."""

    speed = 1.0

    def now(self) -> float:
        return time.time()

    async def sleep_until(self, deadline: float) -> None:
        delay = deadline - self.now()
        if delay > 0:
            await asyncio.sleep(delay)


class AcceleratedClock:
    """Wall-clock time that runs ``speed`` times faster from the moment it is created."""

    def __init__(self, speed: float) -> None:
        if speed <= 0:
            raise ValueError("speed must be positive")
        self.speed = speed
        self._wall0 = time.time()
        self._mono0 = time.monotonic()

    def now(self) -> float:
        return self._wall0 + (time.monotonic() - self._mono0) * self.speed

    async def sleep_until(self, deadline: float) -> None:
        delay = (deadline - self.now()) / self.speed
        if delay > 0:
            await asyncio.sleep(delay)


class SteppedClock:
    """A clock for tests: it moves only when told to."""

    speed = 1.0

    def __init__(self, start: float = 946684800.0) -> None:
        self._now = start
        self._changed = asyncio.Event() if _loop_running() else None

    def now(self) -> float:
        return self._now

    def advance(self, seconds: float) -> float:
        """Move the clock forward by ``seconds`` and return the new time."""
        if seconds < 0:
            raise ValueError("a clock does not run backwards")
        self._now += seconds
        if self._changed is not None:
            self._changed.set()
        return self._now

    async def sleep_until(self, deadline: float) -> None:
        if self._changed is None:
            self._changed = asyncio.Event()
        while self._now < deadline:
            self._changed.clear()
            await self._changed.wait()


class LoopClock:
    """Clock seconds that follow the event loop's own time.

    Starts at the wall clock and then runs with ``loop.time()``. In production that is the
    monotonic clock; a test running a virtual-time event loop gets a bus that runs in virtual
    time, with the host's asyncio timeouts on the same time base.
    """

    speed = 1.0

    def __init__(self, start: float | None = None) -> None:
        self._loop = asyncio.get_running_loop()
        self._offset = (time.time() if start is None else start) - self._loop.time()

    def now(self) -> float:
        return self._loop.time() + self._offset

    async def sleep_until(self, deadline: float) -> None:
        delay = deadline - self.now()
        if delay > 0:
            await asyncio.sleep(delay)


def _loop_running() -> bool:
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return False
    return True


def make_clock(speed: float) -> Clock:
    """The clock for ``--speed FACTOR``."""
    return RealClock() if speed == 1 else AcceleratedClock(speed)

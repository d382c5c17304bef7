"""The sample-and-hold of a bus's real sensors (hctmps1.md §1; DESIGN.md point 4).

The module core calls its :class:`~sondalog.hctmps1.variants.SensorSource` synchronously at
the end of each measurement cycle, so a real sensor is read by :class:`HeldSensor`: a
sample-and-hold whose acquisition task (:meth:`SensorBank.run`) reads every sensor in a
worker thread every ``refresh`` seconds (a DS18B20 conversion takes 750 ms). A value older
than ``hold`` seconds, or no reading at all (a failed CRC, the 85 °C power-on value, a gone
device), counts as no reading; the core then keeps its previous value (its fault path), and
never waits. The sensors themselves are the registered kinds of
:mod:`sondalog.backends.sensor_sources`.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from pathlib import Path

from sondalog.backends.sensor_sources import SensorReader, SourcePlan, open_source

log = logging.getLogger(__name__)

#: Seconds between reads of a source (a module's cycle is 10 s by default).
REFRESH = 2.0
#: Seconds a reading stays valid.
HOLD = 30.0


class NoReading(RuntimeError):
    """The sensor has no valid value now (gone, CRC error, stale, never read)."""


class HeldSensor:
    """One source's sample-and-hold: the module core's ``SensorSource``."""

    def __init__(
        self,
        plan: SourcePlan,
        reader: SensorReader,
        *,
        hold: float = HOLD,
        host_now: Callable[[], float] = time.monotonic,
    ) -> None:
        self.plan = plan
        self.reader = reader
        self.hold = hold
        self.host_now = host_now
        self.value: float | None = None
        self.at = float("-inf")  # host_now() of the last valid reading
        self.failing = False

    def __call__(self, t: float, /) -> float:
        """The held value (``t``, the module clock, is not needed: the hold is host time)."""
        if self.value is None or self.host_now() - self.at > self.hold:
            raise NoReading(f"{self.plan.text}: no valid reading")
        return self.value

    def read(self) -> float | None:
        """Read the sensor now (blocking), scaled: ``reading * scale + offset``."""
        reading = self.reader.read()
        return None if reading is None else reading * self.plan.scale + self.plan.offset

    def store(self, value: float | None) -> None:
        if value is not None:
            self.value, self.at = value, self.host_now()


class SensorBank:
    """The real sensors of a bus's modules and their acquisition task."""

    def __init__(self, root: Path = Path("/"), *, refresh: float = REFRESH) -> None:
        self.root = root
        self.refresh = refresh
        self.sensors: list[HeldSensor] = []
        self._by_plan: dict[SourcePlan, HeldSensor] = {}

    def sensor(self, plan: SourcePlan) -> HeldSensor:
        """The held sensor of ``plan`` (one per source), read by :meth:`run`."""
        held = self._by_plan.get(plan)
        if held is None:
            held = HeldSensor(plan, open_source(plan, self.root))
            self._by_plan[plan] = held
            self.sensors.append(held)
        return held

    def read_all(self) -> list[float | None]:
        """Read every sensor once (blocking; runs in a worker thread)."""
        return [s.read() for s in self.sensors]

    async def acquire(self) -> None:
        """One pass over every sensor, off the event loop."""
        values = await asyncio.to_thread(self.read_all)
        for held, value in zip(self.sensors, values, strict=True):
            if (value is None) != held.failing:  # log changes, not every pass
                held.failing = value is None
                if held.failing:
                    log.warning("%s: no valid reading", held.plan.text)
                else:
                    log.info("%s: reading again", held.plan.text)
            held.store(value)

    async def run(self) -> None:
        """The acquisition task: runs until cancelled."""
        while True:
            try:
                await self.acquire()
            except Exception:  # a device loop never stops (DESIGN.md point 6)
                log.exception("sensor acquisition failed")
            await asyncio.sleep(self.refresh)

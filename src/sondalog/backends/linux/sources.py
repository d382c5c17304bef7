"""Real sensors for HCTMPS1 modules on a Linux board (hctmps1.md §1; DESIGN.md point 4).

A module in the site file measures a real sensor instead of a simulated ``signal``::

    [[bus.modules]]
    id = "T1"
    kind = "temp"
    source = "w1:28-000008d5e4fd"   # a DS18B20 through the kernel's w1 sysfs (°C)

    [[bus.modules]]
    id = "H1"
    kind = "hum"
    source = "iio:ads1115:1"        # IIO device (name or iio:deviceN) and channel
    scale = 31.25                   # physical value = volts * scale + offset (%RH per V)
    offset = -23.8

The module core calls its :class:`~sondalog.hctmps1.variants.SensorSource` synchronously at
the end of each measurement cycle, so the sensor is read by :class:`HeldSensor`: a
sample-and-hold whose acquisition task (:meth:`SensorBank.run`) reads every sensor in a
worker thread every ``refresh`` seconds (a DS18B20 conversion takes 750 ms). A value older
than ``hold`` seconds, a failed CRC or the 85 °C power-on value count as no reading; the core
then keeps its previous value (its fault path), and never waits.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from sondalog.backends.linux.iio import IioChannel, IioError, find_device
from sondalog.backends.linux.w1 import W1Master

log = logging.getLogger(__name__)

#: Seconds between reads of a source (a module's cycle is 10 s by default).
REFRESH = 2.0
#: Seconds a reading stays valid.
HOLD = 30.0
_W1 = re.compile(r"w1:([0-9a-f]{2}-[0-9a-f]{12})")
_IIO = re.compile(r"iio:(.+):(\d+)")


class SourceError(ValueError):
    """A ``source`` the site file names cannot be understood."""


class NoReading(RuntimeError):
    """The sensor has no valid value now (gone, CRC error, stale, never read)."""


@dataclass(frozen=True, slots=True)
class SourceSpec:
    """Where a module's value comes from: ``w1`` (a DS18B20 slave, °C) or ``iio`` (a
    voltage channel); the physical value is ``reading * scale + offset``."""

    text: str
    bus: str  # "w1" or "iio"
    target: str  # the slave name, or the IIO device
    channel: int = 0
    scale: float = 1.0
    offset: float = 0.0


def parse_source(text: str, scale: float = 1.0, offset: float = 0.0) -> SourceSpec:
    """``w1:28-xxxxxxxxxxxx`` or ``iio:DEVICE:CHANNEL``; raises :class:`SourceError`."""
    if match := _W1.fullmatch(text.lower()):
        if not match[1].startswith("28-"):
            raise SourceError(f"{text!r}: only DS18B20 thermometers (family 28) are read")
        return SourceSpec(text, "w1", match[1], 0, scale, offset)
    if match := _IIO.fullmatch(text):
        return SourceSpec(text, "iio", match[1], int(match[2]), scale, offset)
    raise SourceError(
        f"{text!r}: expected w1:28-xxxxxxxxxxxx (a DS18B20) or iio:DEVICE:CHANNEL "
        "(an IIO voltage channel, DEVICE its name or iio:deviceN)"
    )


class HeldSensor:
    """One source's sample-and-hold: the module core's ``SensorSource``."""

    def __init__(
        self,
        spec: SourceSpec,
        root: Path,
        *,
        hold: float = HOLD,
        host_now: Callable[[], float] = time.monotonic,
    ) -> None:
        self.spec = spec
        self.root = root
        self.hold = hold
        self.host_now = host_now
        self.value: float | None = None
        self.at = float("-inf")  # host_now() of the last valid reading
        self._channel: IioChannel | None = None
        self.failing = False

    def __call__(self, t: float, /) -> float:
        """The held value (``t``, the module clock, is not needed: the hold is host time)."""
        if self.value is None or self.host_now() - self.at > self.hold:
            raise NoReading(f"{self.spec.text}: no valid reading")
        return self.value

    def read(self) -> float | None:
        """Read the sensor now (blocking: a DS18B20 conversion takes 750 ms)."""
        spec = self.spec
        if spec.bus == "w1":
            reading = self._read_w1()
        else:
            try:
                if self._channel is None:
                    self._channel = IioChannel(find_device(self.root, spec.target), spec.channel)
                reading = self._channel.volts()
            except IioError:
                self._channel = None
                reading = None
        return None if reading is None else reading * spec.scale + spec.offset

    def _read_w1(self) -> float | None:
        devices = self.root / "sys/bus/w1/devices"
        with contextlib.suppress(OSError):
            for master in sorted(devices.glob("w1_bus_master*")):
                if (master / self.spec.target).is_dir():
                    return W1Master(master).read(self.spec.target)
        return None

    def store(self, value: float | None) -> None:
        if value is not None:
            self.value, self.at = value, self.host_now()


class SensorBank:
    """The real sensors of a bus's modules and their acquisition task."""

    def __init__(self, root: Path = Path("/"), *, refresh: float = REFRESH) -> None:
        self.root = root
        self.refresh = refresh
        self.sensors: list[HeldSensor] = []
        self._by_spec: dict[SourceSpec, HeldSensor] = {}

    def sensor(self, spec: SourceSpec) -> HeldSensor:
        """The held sensor of ``spec`` (one per source), read by :meth:`run`."""
        held = self._by_spec.get(spec)
        if held is None:
            held = self._by_spec[spec] = HeldSensor(spec, self.root)
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
                    log.warning("%s: no valid reading", held.spec.text)
                else:
                    log.info("%s: reading again", held.spec.text)
            held.store(value)

    async def run(self) -> None:
        """The acquisition task: runs until cancelled."""
        while True:
            try:
                await self.acquire()
            except Exception:  # a device loop never stops (DESIGN.md point 6)
                log.exception("sensor acquisition failed")
            await asyncio.sleep(self.refresh)

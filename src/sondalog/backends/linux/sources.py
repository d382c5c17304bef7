"""Real sensors for HCTMPS1 modules on a Linux board (hctmps1.md §1; DESIGN.md point 4).

Two sensor source kinds, registered by name in :mod:`sondalog.backends.sensor_sources`::

    [[bus.modules]]
    id = "T1"
    kind = "temp"
    source = "w1:28-000008d5e4fd"   # a DS18B20 through the kernel's w1 sysfs (°C)

    [[bus.modules]]
    id = "H1"
    kind = "hum"
    source = "iio:ads1115:1"        # IIO device (name or iio:deviceN) and channel (volts)
    scale = 31.25                   # physical value = volts * scale + offset (%RH per V)
    offset = -23.8

The readers block (a DS18B20 conversion takes 750 ms): the bus's
:class:`~sondalog.backends.sensor_bank.SensorBank` calls them in a worker thread.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass
from pathlib import Path

from sondalog.backends.linux.iio import IioChannel, IioError, find_device
from sondalog.backends.linux.w1 import W1Master
from sondalog.backends.sensor_sources import SourceKind
from sondalog.config import Table
from sondalog.hctmps1.variants import Kind

_W1 = re.compile(r"[0-9a-f]{2}-[0-9a-f]{12}")
_IIO = re.compile(r"(.+):(\d+)")


@dataclass(frozen=True, slots=True)
class W1Source:
    """A DS18B20 on any 1-Wire master: its slave name (``28-...``)."""

    slave: str


@dataclass(frozen=True, slots=True)
class IioSource:
    """A voltage channel of an IIO device (its name, or ``iio:deviceN``)."""

    device: str
    channel: int


def parse_w1(address: str, module: Table, kind: Kind) -> W1Source:
    """``28-xxxxxxxxxxxx`` (``source = "w1:..."``); the module must measure temperature."""
    slave = address.lower()
    if not _W1.fullmatch(slave):
        raise ValueError("expected w1:28-xxxxxxxxxxxx (a DS18B20's slave name)")
    if not slave.startswith("28-"):
        raise ValueError("only DS18B20 thermometers (family 28) are read")
    if kind is not Kind.TEMP:
        raise ValueError("a DS18B20 measures temperature: kind must be 'temp'")
    return W1Source(slave)


def parse_iio(address: str, module: Table, kind: Kind) -> IioSource:
    """``DEVICE:CHANNEL`` (``source = "iio:..."``)."""
    match = _IIO.fullmatch(address)
    if match is None:
        raise ValueError(
            "expected iio:DEVICE:CHANNEL (an IIO voltage channel, DEVICE its name or iio:deviceN)"
        )
    return IioSource(match[1], int(match[2]))


class W1Reader:
    """A DS18B20 on whichever w1 bus master has it (°C; ``None``: gone, CRC, 85 °C)."""

    def __init__(self, source: W1Source, root: Path) -> None:
        self.slave = source.slave
        self.devices = root / "sys/bus/w1/devices"

    def read(self) -> float | None:
        with contextlib.suppress(OSError):
            for master in sorted(self.devices.glob("w1_bus_master*")):
                if (master / self.slave).is_dir():
                    return W1Master(master).read(self.slave)
        return None


class IioReader:
    """An IIO voltage channel (volts), found again after a failure."""

    def __init__(self, source: IioSource, root: Path) -> None:
        self.source = source
        self.root = root
        self._channel: IioChannel | None = None

    def read(self) -> float | None:
        try:
            if self._channel is None:
                device = find_device(self.root, self.source.device)
                self._channel = IioChannel(device, self.source.channel)
            return self._channel.volts()
        except IioError:
            self._channel = None
            return None


W1_SOURCE = SourceKind(form="w1:28-xxxxxxxxxxxx (a DS18B20)", parse=parse_w1, open=W1Reader)
IIO_SOURCE = SourceKind(
    form="iio:DEVICE:CHANNEL (an IIO voltage channel, DEVICE its name or iio:deviceN)",
    parse=parse_iio,
    open=IioReader,
)

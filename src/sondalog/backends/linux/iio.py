"""A/D inputs through the Linux Industrial I/O subsystem (§6.4, §6.5.5; spec notes §7).

A channel is ``<root>/sys/bus/iio/devices/iio:deviceN/in_voltageM_raw`` with its scale and
offset in ``in_voltageM_scale`` / ``in_voltageM_offset`` or, shared by all channels of the
device, ``in_voltage_scale`` / ``in_voltage_offset``. The kernel's ABI gives millivolts::

    volts = (raw + offset) * scale / 1000

The logger's core wants a reading *normalised* to its A/D converter: the fraction of the
reference voltage (2.5 V internal, or the external reference for addresses 32..36),
saturating at both ends and quantised to 12 bits like the MSP430's converter
(:mod:`sondalog.ala1.hardware`). Reads are blocking: callers run them in a worker thread.
"""

from __future__ import annotations

import re
from pathlib import Path

from sondalog.ala1.hardware import INTERNAL_REFERENCE as INTERNAL_REFERENCE
from sondalog.ala1.hardware import normalise as normalise


class IioError(ValueError):
    """An IIO device or channel named in the board file does not exist."""


def find_device(root: Path, spec: str) -> Path:
    """The sysfs directory of an IIO device: ``iio:deviceN`` or the device's ``name``
    (``ads1115``), which survives renumbering at boot."""
    devices = root / "sys/bus/iio/devices"
    if re.fullmatch(r"iio:device\d+", spec):
        path = devices / spec
        if path.is_dir():
            return path
        raise IioError(f"no IIO device {spec} in {devices}")
    found = []
    try:
        for path in sorted(devices.iterdir()):
            try:
                if (path / "name").read_text().strip() == spec:
                    found.append(path)
            except OSError:
                continue
    except OSError:
        pass
    if len(found) == 1:
        return found[0]
    if found:
        names = ", ".join(p.name for p in found)
        raise IioError(f"several IIO devices are named {spec!r} ({names}): use iio:deviceN")
    raise IioError(f"no IIO device named {spec!r} in {devices}")


def _read_number(path: Path) -> float | None:
    try:
        return float(path.read_text().strip())
    except (OSError, ValueError):
        return None


class IioChannel:
    """One voltage channel (``in_voltageM``) of an IIO device."""

    def __init__(self, device: Path, channel: int) -> None:
        self.device = device
        self.channel = channel
        self.raw_path = device / f"in_voltage{channel}_raw"
        if not self.raw_path.exists():
            raise IioError(f"{device.name} has no channel in_voltage{channel}_raw")

    def _attribute(self, name: str) -> Path | None:
        for path in (
            self.device / f"in_voltage{self.channel}_{name}",
            self.device / f"in_voltage_{name}",
        ):
            if path.exists():
                return path
        return None

    def volts(self) -> float | None:
        """The channel's voltage now, or None when the read fails."""
        raw = _read_number(self.raw_path)
        if raw is None:
            return None
        scale_path, offset_path = self._attribute("scale"), self._attribute("offset")
        scale = _read_number(scale_path) if scale_path is not None else 1.0
        offset = _read_number(offset_path) if offset_path is not None else 0.0
        if scale is None or offset is None:
            return None
        return (raw + offset) * scale / 1000.0

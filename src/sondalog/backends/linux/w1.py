"""DS18B20 thermometers through the Linux kernel's 1-Wire sysfs (§6.4.3.1, §6.4.3.1.1).

The kernel (``w1-gpio`` + ``w1_therm``) lists the slaves of a bus master as
``<root>/sys/bus/w1/devices/w1_bus_masterN/28-xxxxxxxxxxxx``. A slave's name is the family
byte, a dash and the 48-bit serial number as one hexadecimal number; the logger writes the
whole 64-bit ROM code as one hexadecimal number with the family code 0x28 in the lowest byte
and the Dallas CRC-8 in the highest (§6.4.3.1.1, :func:`sondalog.ala1.hardware.rom_code`)::

    sysfs  28-000008d5e4fd   <->   logger  46000008D5E4FD28   (46 = CRC-8 of 28 fd e4 d5 08 00 00)

Every function here does blocking file I/O: callers run them in a worker thread.
"""

from __future__ import annotations

import re
from pathlib import Path

from sondalog.ala1.hardware import DS18B20_FAMILY, dallas_crc8

#: The power-on value of a DS18B20's scratchpad: a sensor that did not convert (§7 notes).
POWER_ON_MILLI = 85_000
_SLAVE = re.compile(r"^([0-9a-f]{2})-([0-9a-f]{12})$")
_W1_SLAVE_CRC = re.compile(r"^((?:[0-9a-f]{2} ){9}): crc=([0-9a-f]{2}) (YES|NO)$")
_W1_SLAVE_T = re.compile(r"^(?:[0-9a-f]{2} ){9}t=(-?\d+)$")


def rom_from_slave(name: str) -> int:
    """The logger's 64-bit ROM code of the sysfs slave ``name`` (``28-000008d5e4fd``)."""
    match = _SLAVE.match(name.lower())
    if match is None:
        raise ValueError(f"not a 1-Wire slave name: {name!r}")
    body = bytes([int(match[1], 16)]) + int(match[2], 16).to_bytes(6, "little")
    return int.from_bytes(body + bytes([dallas_crc8(body)]), "little")


def slave_from_rom(rom: int) -> str:
    """The sysfs slave name of a logger ROM code; ``ValueError`` if the CRC-8 is wrong."""
    if not 0 <= rom < 1 << 64:
        raise ValueError(f"a ROM code has 64 bits: {rom:#x}")
    raw = rom.to_bytes(8, "little")
    if dallas_crc8(raw[:7]) != raw[7]:
        raise ValueError(f"ROM code {rom:016X} has a wrong CRC-8 (highest byte)")
    return f"{raw[0]:02x}-{int.from_bytes(raw[1:7], 'little'):012x}"


def millis_to_celsius(milli: int) -> float | None:
    """Kernel millidegrees -> degrees on the sensor's 1/16 °C grid; 85 °C reads as None."""
    if milli == POWER_ON_MILLI:
        return None
    celsius = round(milli / 1000 * 16) / 16
    return celsius if -55.0 <= celsius <= 125.0 else None


def parse_w1_slave(text: str) -> float | None:
    """The temperature in a ``w1_slave`` file, or None (failed CRC, 85 °C, garbage).

    Format (two lines; the nine scratchpad bytes, then the kernel's CRC verdict and ``t=``)::

        72 01 4b 46 7f ff 0e 10 57 : crc=57 YES
        72 01 4b 46 7f ff 0e 10 57 t=23125
    """
    lines = text.strip().splitlines()
    if len(lines) != 2:
        return None
    crc_line, t_line = _W1_SLAVE_CRC.match(lines[0].strip()), _W1_SLAVE_T.match(lines[1].strip())
    if crc_line is None or t_line is None or crc_line[3] != "YES":
        return None
    scratch = bytes.fromhex(crc_line[1])
    if dallas_crc8(scratch[:8]) != scratch[8] or not any(scratch):
        return None  # the kernel said YES to an all-zero or inconsistent scratchpad
    return millis_to_celsius(int(t_line[1]))


class W1Master:
    """One 1-Wire bus master directory (``w1_bus_masterN``)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def slaves(self) -> list[str]:
        """Names of the DS18B20 slaves the kernel found on this bus, sorted."""
        try:
            entries = [p.name for p in self.path.iterdir()]
        except OSError:
            return []
        prefix = f"{DS18B20_FAMILY:02x}-"
        return sorted(n for n in entries if n.startswith(prefix) and _SLAVE.match(n))

    @property
    def has_bulk(self) -> bool:
        """Whether the master offers ``therm_bulk_read`` (Linux 5.10+ ``w1_therm``)."""
        return (self.path / "therm_bulk_read").exists()

    def trigger(self) -> bool:
        """Start a conversion on every sensor of the bus at once; False if it could not."""
        if not self.has_bulk:
            return False
        try:
            (self.path / "therm_bulk_read").write_text("trigger\n")
        except OSError:
            return False
        return True

    def converting(self) -> bool:
        """True while a bulk conversion is still running (``therm_bulk_read`` reads -1)."""
        try:
            return (self.path / "therm_bulk_read").read_text().strip() == "-1"
        except OSError:
            return False

    def read(self, slave: str) -> float | None:
        """The temperature of ``slave`` in °C, or None: ``temperature`` where the kernel
        offers it, else ``w1_slave`` (both start their own conversion when none is pending)."""
        base = self.path / slave
        try:
            text = (base / "temperature").read_text()
        except FileNotFoundError:
            pass
        except OSError:
            return None  # the kernel's read failed (CRC, sensor gone)
        else:
            text = text.strip()
            return millis_to_celsius(int(text)) if re.fullmatch(r"-?\d+", text) else None
        try:
            return parse_w1_slave((base / "w1_slave").read_text())
        except OSError:
            return None


def find_masters(root: Path) -> list[str]:
    """Names of the 1-Wire bus masters under ``root`` (for ``sondalog`` error messages)."""
    devices = root / "sys/bus/w1/devices"
    try:
        return sorted(p.name for p in devices.iterdir() if p.name.startswith("w1_bus_master"))
    except OSError:
        return []

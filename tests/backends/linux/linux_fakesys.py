"""Fake kernel trees for the linux backend: w1 and IIO sysfs in a temporary directory."""

from __future__ import annotations

from pathlib import Path

from sondalog.ala1.hardware import dallas_crc8


def scratchpad(celsius: float) -> bytes:
    """A DS18B20 scratchpad holding ``celsius`` (12-bit), with its CRC-8."""
    raw = round(celsius * 16).to_bytes(2, "little", signed=True)
    body = raw + bytes([0x4B, 0x46, 0x7F, 0xFF, 0x0C, 0x10])
    return body + bytes([dallas_crc8(body)])


def w1_slave_text(celsius: float, *, crc_ok: bool = True) -> str:
    """What the kernel shows in ``w1_slave`` for a sensor at ``celsius``."""
    pad = scratchpad(celsius)
    hexes = " ".join(f"{b:02x}" for b in pad)
    verdict = "YES" if crc_ok else "NO"
    return f"{hexes} : crc={pad[8]:02x} {verdict}\n{hexes} t={int(celsius * 1000)}\n"


class FakeW1:
    """``<root>/sys/bus/w1/devices/w1_bus_masterN`` with slaves."""

    def __init__(self, root: Path, master: str = "w1_bus_master1", *, bulk: bool = True):
        self.path = root / "sys/bus/w1/devices" / master
        self.path.mkdir(parents=True, exist_ok=True)
        if bulk:
            (self.path / "therm_bulk_read").write_text("0\n")

    def sensor(self, name: str, celsius: float | None, *, modern: bool = True) -> Path:
        """A slave directory: ``temperature`` (modern kernels) or only ``w1_slave``."""
        slave = self.path / name
        slave.mkdir(exist_ok=True)
        self.set(name, celsius, modern=modern)
        return slave

    def set(self, name: str, celsius: float | None, *, modern: bool = True) -> None:
        slave = self.path / name
        for f in ("temperature", "w1_slave"):
            (slave / f).unlink(missing_ok=True)
        if celsius is None:
            return
        if modern:
            (slave / "temperature").write_text(f"{int(celsius * 1000)}\n")
        (slave / "w1_slave").write_text(w1_slave_text(celsius))

    def remove(self, name: str) -> None:
        slave = self.path / name
        for f in slave.iterdir():
            f.unlink()
        slave.rmdir()

    @property
    def bulk_text(self) -> str:
        return (self.path / "therm_bulk_read").read_text()


class FakeIio:
    """``<root>/sys/bus/iio/devices/iio:deviceN`` with voltage channels."""

    def __init__(self, root: Path, number: int = 0, name: str = "ads1115", scale: float = 0.125):
        self.path = root / f"sys/bus/iio/devices/iio:device{number}"
        self.path.mkdir(parents=True, exist_ok=True)
        (self.path / "name").write_text(name + "\n")
        (self.path / "in_voltage_scale").write_text(f"{scale}\n")

    def raw(self, channel: int, value: int) -> None:
        (self.path / f"in_voltage{channel}_raw").write_text(f"{value}\n")

    def attribute(self, name: str, value: float) -> None:
        (self.path / name).write_text(f"{value}\n")

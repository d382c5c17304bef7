"""Hardware backends registered by name, and the acquisition hint of the port (issue 10)."""

from __future__ import annotations

from pathlib import Path

import pytest

from sondalog.ala1 import Engine, Identity
from sondalog.ala1.hardware import NoHardware
from sondalog.backends import registry
from sondalog.backends.registry import BackendContext, UnknownBackend
from sondalog.backends.sim.logger import SimHardware
from sondalog.backends.store.ala1_nv import SqliteNvStore
from sondalog.config import read_site_file

T0 = 1_000_000_000.0


def test_sim_and_linux_are_known_by_name() -> None:
    assert {"sim", "linux"} <= set(registry.names())
    hardware = registry.create("sim", BackendContext({"logger": {"seed": 3}}, start=T0))
    assert isinstance(hardware, SimHardware)


def test_an_unknown_backend_is_a_clear_error() -> None:
    with pytest.raises(UnknownBackend, match=r"no hardware backend 'nowhere'.*sim"):
        registry.create("nowhere", BackendContext())


def test_a_backend_registers_itself_by_name() -> None:
    made = NoHardware()
    registry.register("test-null", lambda context: made)
    assert registry.create("test-null", BackendContext()) is made
    assert "test-null" in registry.names()


class _Recording(NoHardware):
    def __init__(self) -> None:
        self.prepared: list[float] = []

    def prepare(self, t: float) -> None:
        self.prepared.append(t)


def test_the_core_tells_the_hardware_its_next_sampling_instant() -> None:
    """Asynchronous acquisition: a backend learns the next instant ahead of it."""
    hardware = _Recording()
    engine = Engine(Identity(), SqliteNvStore(":memory:"), T0, hardware)
    line = engine.open_line()
    engine.receive(line, b"write channel 1 sampling period 000010\r", T0)
    assert hardware.prepared, "no hint after a schedule was set"
    assert engine.next_deadline() == hardware.prepared[-1]  # the instant the core wakes for
    engine.advance(T0 + 100)
    upcoming = hardware.prepared[-1]
    assert T0 + 100 < upcoming <= T0 + 110
    assert engine.next_deadline() == upcoming


def test_linux_is_chosen_by_name_from_a_site_file(tmp_path: Path) -> None:
    """``backend = "linux"``: the registry builds the board's hardware on a fake root."""
    from linux.linux_fakesys import FakeW1  # the fake sysfs tree of the linux tests

    FakeW1(tmp_path).sensor("28-000008d5e4fd", 21.5)
    site = tmp_path / "site.toml"
    site.write_text(
        '[logger]\nbackend = "linux"\n[board]\n'
        '[[board.ds18b20]]\npin = 4\nmaster = "w1_bus_master1"\n'
    )
    data, text = read_site_file(site)
    hardware = registry.create("linux", BackendContext(data, site, text, T0, root=tmp_path))
    assert type(hardware).__name__ == "LinuxHardware"

"""``sondalog logger serve --site`` with ``backend = "linux"``: the board's acquisition task
runs with the logger (it did only under ``sondalog serve`` before), and the sensors are read
under ``SONDALOG_ROOT``; closing the logger stops the task."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from linux_fakesys import FakeW1

from sondalog.ala1.hardware import DS18B20_SCALE
from sondalog.app.logger import logger_hardware, start_logger
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.backends.linux.w1 import rom_from_slave
from sondalog.io.clock import RealClock

SENSOR = "28-000008d5e4fd"


def test_logger_serve_acquires_from_the_board(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    asyncio.run(_serve_and_read(tmp_path, monkeypatch))


async def _serve_and_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "root"
    FakeW1(root).sensor(SENSOR, 21.5)
    site = tmp_path / "site.toml"
    site.write_text(
        '[logger]\nbackend = "linux"\n[board]\n'
        '[[board.ds18b20]]\npin = 4\nmaster = "w1_bus_master1"\n'
    )
    monkeypatch.setenv("SONDALOG_ROOT", str(root))
    clock = RealClock()
    hardware = logger_hardware(site, clock.now())
    assert isinstance(hardware, LinuxHardware)
    logger = await start_logger(tmp_path / "state", clock, ("127.0.0.1", 0), hardware=hardware)
    try:
        reading = None
        for _ in range(200):  # the first pass runs at once; a conversion takes 750 ms
            reading = hardware.ds18b20(4, rom_from_slave(SENSOR), hardware.host_now())
            if reading is not None:
                break
            await asyncio.sleep(0.05)
        assert reading is not None and reading[1] * DS18B20_SCALE == pytest.approx(21.5)
    finally:
        await logger.close()
    assert logger.acquisition is not None and logger.acquisition.done()

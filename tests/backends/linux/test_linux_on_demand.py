"""An on-demand read through the Linux backend (§6.5.8): the core's ``prepare(ready_at)`` of a
waiting read makes the backend convert the DS18B20 for it, so the answer is the sensor's value
now, not the sample-and-hold's last periodic reading."""

from __future__ import annotations

import asyncio
from pathlib import Path

from test_linux_logger import SENSOR, Board

from sondalog.backends.linux.w1 import rom_from_slave


def test_a_waiting_read_gets_a_fresh_conversion(tmp_path: Path) -> None:
    board = Board(tmp_path)

    async def scenario() -> tuple[str, str, float]:
        cmd = board.until
        rom = rom_from_slave(SENSOR)
        for line in (
            "write device 3 type ds18b20",
            "write device 3 address 4",
            "write channel 2 device 3",
            "write channel 2 type 3",
            "write channel 2 switch output 0",
            "write channel 2 format 0.1",
            f"write channel 2 address x {rom:016X}",
        ):
            assert await cmd(None, line) == "OK\r\n", line
        first = await cmd(None, "read channel 2 value")
        board.w1.set(SENSOR, 25.25)  # warmer now; the periodic refresh is 10 s away
        asked = board.logger.clock.now()
        second = await cmd(None, "read channel 2 value")
        waited = board.logger.clock.now() - asked
        return first, second, waited

    first, second, waited = asyncio.run(scenario())
    assert first.split()[0] == "18.5"
    assert second.split()[0] == "25.3"  # 25.25 °C in format 0.1
    assert waited < 1.0  # one 750 ms conversion, not the next refresh

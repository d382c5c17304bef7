"""End to end in-process: the ALA1 core samples through LinuxHardware over fake kernel trees.

The virtual logger's engine (the real core) is driven on a stepped clock; the acquisition
passes run whenever the backend asks for one (:meth:`LinuxHardware.next_acquisition`), as
its task does on a board.
"""

from __future__ import annotations

import asyncio
import tomllib
from pathlib import Path

from linux_fakesys import FakeIio, FakeW1

from sondalog.app.virtual import VirtualLogger
from sondalog.backends.linux import parse_board
from sondalog.backends.linux.fakegpio import FakeChip
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.backends.linux.w1 import rom_from_slave

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
SENSOR = "28-000008d5e4fd"
OTHER = "28-0000055a1b2c"
START = 1_000_000_000.0


class Board:
    """The Raspberry Pi example board over fake trees, and a logger using it."""

    def __init__(self, root: Path) -> None:
        self.w1 = FakeW1(root, bulk=False)
        self.w1.sensor(SENSOR, 18.5)
        self.iio = FakeIio(root, 0, "ads1115", scale=0.125)
        self.iio.raw(0, 12000)  # 1.5 V: the water level
        self.iio.raw(3, 8727)  # 12.0 V through 1:11
        text = (EXAMPLES / "board-raspberrypi.toml").read_text()
        board = parse_board(tomllib.loads(text))
        loggers: list[VirtualLogger] = []

        def now() -> float:  # the logger's stepped clock is the host clock of this world
            return loggers[0].clock.now()

        self.chip = FakeChip(clock=now)
        self.hw = LinuxHardware(board, root=root, chips={"gpiochip0": self.chip}, host_now=now)
        self.logger = VirtualLogger(hardware=self.hw, start=START)  # type: ignore[arg-type]
        loggers.append(self.logger)

    async def until(self, target: float | None, line: str | None = None) -> str:
        """Run the core and the acquisition passes up to host time ``target`` (or until the
        answer to ``line`` is complete)."""
        logger, engine = self.logger, self.logger.engine
        answer = b""
        if line is not None:
            answer = logger.send(line.encode() + b"\r")
        while True:
            now = logger.clock.now()
            if self.hw.next_acquisition() <= now:
                await self.hw.acquire()
                continue
            if (line is not None and answer.endswith(b"OK\r\n")) or (
                line is not None and answer.endswith(b"ERROR\r\n")
            ):
                return answer.decode()
            steps = [self.hw.next_acquisition()]
            deadline = engine.next_deadline()
            if deadline is not None:
                steps.append(deadline)
            if target is not None:
                steps.append(target)
            nxt = max(now, min(steps))
            if target is not None and now >= target:
                return answer.decode()
            logger.clock.advance(nxt - now)
            out = engine.advance(logger.clock.now())
            answer += b"".join(o.data for o in out if o.line == logger.line)


def test_the_core_reads_and_samples_through_the_linux_backend(tmp_path: Path) -> None:
    board = Board(tmp_path)

    async def scenario() -> None:
        cmd = board.until
        assert await cmd(None, "write date 20070301090000") == "OK\r\n"
        # a DS18B20 by ROM code on P6 bit 4 (the 1-Wire bus of GPIO4)
        rom = rom_from_slave(SENSOR)
        for line in (
            "write device 3 type ds18b20",
            "write device 3 address 4",
            "write channel 2 device 3",
            "write channel 2 type 3",
            "write channel 2 switch output 0",
            f"write channel 2 address x {rom:016X}",
        ):
            assert await cmd(None, line) == "OK\r\n", line
        assert float((await cmd(None, "read channel 2 value")).split()[0]) == 18.5
        # §6.4.3.1.1: a detection address learns the code of the only sensor on the pin
        await cmd(None, "write channel 2 address x FF00")
        await cmd(None, "read channel 2 value")
        learned = (await cmd(None, "read channel 2 address x")).split()[0]
        assert int(learned, 16) == rom & ~0xFF
        # the water level on input 16, powered through output 2 = GPIO27 (active low)
        for line in (
            "write output 2 device 1",
            "write output 2 address 6",
            "write channel 3 type 3",
            "write channel 3 address 16",
            "write channel 3 switch output 2",
            "write channel 3 switch advance 2",
        ):
            assert await cmd(None, line) == "OK\r\n", line
        value = await cmd(None, "read channel 3 value")
        assert float(value.split()[0]) == 1.5, value
        assert (27, True) in board.chip.history  # the relay was switched on for the read
        # the rain gauge on the timer input: pulses by kernel timestamp, one row a minute
        for line in (
            "write channel max number 4",
            "write device 4 type msp430ta",
            "write channel 4 device 4",
            "write channel 4 type 2",
            "write channel 4 switch output 0",
            "write channel 4 sampling period 000100",
            "write channel 4 sampling start 20070301090100",
            "write channel 4 record change 0",
            "write channel 2 sampling period 000100",
            "write channel 2 sampling start 20070301090100",
            "write channel 2 record change 0",
            f"write channel 2 address x {rom:016X}",
        ):
            assert await cmd(None, line) == "OK\r\n", line
        offset = board.logger.engine.state.clock_offset
        host_0901 = 1172739660.0 - offset  # 2007-03-01 09:01:00 UTC in module seconds
        for k, n in enumerate((3, 0, 5)):
            for i in range(n):
                board.chip.pulse_at(17, host_0901 + 60 * k + 1 + i)
        board.w1.set(SENSOR, 19.5)
        await cmd(host_0901 + 3 * 60 + 1)
        rows = await cmd(None, "read record 3 from date/20070301090200/")
        assert rows.splitlines() == [
            "20070301090200.0,1,,19.5,,3.0",
            "20070301090300.0,1,,19.5,,0.0",
            "20070301090400.0,1,,19.5,,5.0",
            "OK",
        ], rows

    asyncio.run(scenario())
    board.hw.close()
    board.logger.close()

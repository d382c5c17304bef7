"""LinuxHardware: the sample-and-hold cache over fake sysfs/IIO trees and the fake chip."""

from __future__ import annotations

import asyncio
import tomllib
from pathlib import Path

import pytest
from linux_fakesys import FakeIio, FakeW1

from sondalog.ala1.hardware import DS18B20_SCALE, Hardware
from sondalog.backends.linux import NAME, open_board, parse_board
from sondalog.backends.linux.fakegpio import FakeChip
from sondalog.backends.linux.hardware import LinuxHardware
from sondalog.backends.linux.w1 import rom_from_slave
from sondalog.config import ConfigError

BOARD = """\
[board]
hold = 30
external_reference = 2.0
settle = 0.5

[[board.ds18b20]]
pin = 4
master = "w1_bus_master1"

[[board.ds18b20]]
pin = 5
master = "w1_bus_master2"
power = 3

[[board.analog]]
address = 16
iio = "ads1115"
channel = 0

[[board.analog]]
address = 33
iio = "ads1115"
channel = 1
gain = 2.0
power = 2

[board.supply]
iio = "iio:device0"
channel = 3
gain = 11.0

[[board.pulses]]
timer = true
chip = "gpiochip0"
line = "GPIO17"

[[board.pulses]]
address = 18
chip = "gpiochip0"
line = 22
edge = "rising"

[[board.outputs]]
output = 2
chip = "gpiochip0"
line = 27
"""
A = "28-000008d5e4fd"
B = "28-0000055a1b2c"


class World:
    def __init__(self, root: Path, *, bulk: bool = False) -> None:
        self.now = 1_000_000.0
        self.w1 = FakeW1(root, bulk=bulk)
        self.w1.sensor(A, 21.5)
        self.w1b = FakeW1(root, "w1_bus_master2", bulk=bulk)
        self.w1b.sensor(B, -3.25)
        self.iio = FakeIio(root, 0, "ads1115", scale=0.125)
        self.iio.raw(0, 8000)  # 1.0 V
        self.iio.raw(1, 4000)  # 0.5 V, x2 = 1.0 V on an external-reference input
        self.iio.raw(3, 8727)  # 1.0909 V x 11 = 12.0 V
        self.chip = FakeChip(clock=lambda: self.now)
        board = parse_board(tomllib.loads(BOARD))
        self.hw = LinuxHardware(
            board, root=root, chips={"gpiochip0": self.chip}, host_now=lambda: self.now
        )


def test_reads_come_from_the_cache_filled_by_a_pass(tmp_path: Path) -> None:
    world = World(tmp_path)
    hw: Hardware = world.hw
    t = world.now
    assert hw.adc(1, 16, t) is None and hw.ds18b20(4, 0, t) is None  # nothing acquired yet
    asyncio.run(world.hw.acquire())
    assert hw.adc(1, 16, t) == pytest.approx(round(0.4 * 4095) / 4095)  # 1.0 V of 2.5 V
    assert hw.adc(1, 17, t) is None  # not wired
    assert hw.supply(t) == pytest.approx(round(12.0 / 11 / 2.5 * 4095) / 4095, abs=1e-3)
    rom_a = rom_from_slave(A)
    assert hw.ds18b20(4, rom_a, t) == (rom_a, 21.5 / DS18B20_SCALE)
    assert hw.ds18b20(4, 0, t) == (rom_a, 21.5 / DS18B20_SCALE)
    assert hw.ds18b20(4, 0xFF00, t) == (rom_a, 21.5 / DS18B20_SCALE)  # detection address
    assert hw.ds18b20(4, rom_from_slave(B), t) is None  # that one is on another bus
    assert hw.ds18b20(6, 0, t) is None
    assert hw.gsm("signal", t) is None
    assert hw.adc(1, 16, t + 31) is None  # held 30 s, then no valid value


def test_two_sensors_on_one_bus_need_their_rom_codes(tmp_path: Path) -> None:
    world = World(tmp_path)
    world.w1.sensor(B, 85.0)  # a second sensor on bus 1 that has not converted
    asyncio.run(world.hw.acquire())
    assert world.hw.ds18b20(4, 0, world.now) is None  # a collision, as on the module
    assert world.hw.ds18b20(4, rom_from_slave(B), world.now) is None  # 85 °C: no value
    world.w1.set(B, 19.0, modern=False)
    world.w1.remove(A)
    world.now += 5
    asyncio.run(world.hw.acquire())
    assert world.hw.ds18b20(4, 0, world.now) == (rom_from_slave(B), 19.0 / DS18B20_SCALE)
    assert world.hw.ds18b20(4, rom_from_slave(A), world.now) is None  # gone from the bus


def test_switched_inputs_need_power_and_a_read_after_it(tmp_path: Path) -> None:
    world = World(tmp_path)
    hw = world.hw
    asyncio.run(hw.acquire())
    assert hw.adc(1, 33, world.now) is None  # output 2 off
    assert hw.ds18b20(5, 0, world.now) is None  # output 3 off
    hw.set_output(2, True, world.now)
    hw.set_output(3, True, world.now)
    assert world.chip.levels[27] is True
    assert hw.adc(1, 33, world.now) is None  # the value was read before power-on
    assert hw.next_acquisition() == pytest.approx(world.now + 0.5)  # settle, then read
    world.now += 0.5
    asyncio.run(hw.acquire())
    assert hw.adc(1, 33, world.now) == pytest.approx(round(1.0 / 2.0 * 4095) / 4095)
    assert hw.ds18b20(5, 0, world.now) == (rom_from_slave(B), -3.25 / DS18B20_SCALE)
    hw.set_output(2, False, world.now)
    assert world.chip.levels[27] is False and hw.adc(1, 33, world.now) is None


def test_pulses_by_input(tmp_path: Path) -> None:
    world = World(tmp_path)
    t0 = world.now
    for dt in (0.1, 0.2, 5.0):
        world.chip.pulse_at(17, t0 + dt)
    world.chip.pulse_at(22, t0 + 1.0, rising=True)
    world.chip.pulse_at(22, t0 + 2.0, rising=False)  # input 18 counts rising edges only
    world.now += 10
    assert world.hw.pulses(4, 0, True, t0, t0 + 5.0) == 2
    assert world.hw.pulses(4, 0, True, t0, t0 + 10) == 3
    assert world.hw.pulses(1, 18, False, t0, t0 + 10) == 1
    assert world.hw.pulses(1, 34, False, t0, t0 + 10) == 1  # 34 = the pin of 18
    assert world.hw.pulses(1, 19, False, t0, t0 + 10) == 0


def test_the_acquisition_task_bulk_converts_and_takes_edges(tmp_path: Path) -> None:
    """run(): a bulk conversion is triggered for a prepared read and edge events arrive
    through the event loop's reader on the request's fd (real time: about one second)."""
    world = World(tmp_path, bulk=True)
    hw = world.hw

    async def scenario() -> None:
        task = asyncio.create_task(hw.run())
        try:
            await asyncio.sleep(0.05)
            assert world.w1.bulk_text == "trigger\n"  # the first pass converts at once
            world.chip.pulse_at(17, world.now - 1)
            for _ in range(100):
                await asyncio.sleep(0.02)
                if hw.ds18b20(4, 0, world.now) is not None:
                    break
            assert hw.ds18b20(4, 0, world.now) == (rom_from_slave(A), 21.5 / DS18B20_SCALE)
            counter = hw._pulses[0].counter
            assert counter.count(hw._pulses[0].offset, world.now - 2, world.now) == 1
            world.w1.set(A, 22.0)
            hw.prepare(world.now)  # due now: a new pass starts
            for _ in range(100):
                await asyncio.sleep(0.02)
                if hw.ds18b20(4, 0, world.now) == (rom_from_slave(A), 22.0 / DS18B20_SCALE):
                    break
            assert hw.ds18b20(4, 0, world.now) == (rom_from_slave(A), 22.0 / DS18B20_SCALE)
        finally:
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task

    asyncio.run(scenario())


def test_missing_resources_are_named_in_the_board_file(tmp_path: Path) -> None:
    text = '[board]\n\n[[board.ds18b20]]\npin = 4\nmaster = "w1_bus_master9"\n'
    path = tmp_path / "board.toml"
    board = parse_board(tomllib.loads(text), path, text)
    FakeW1(tmp_path)
    with pytest.raises(ConfigError, match=r"board.toml:5: .*master.*found: w1_bus_master1"):
        open_board(board, root=tmp_path)
    text = '[board]\n[[board.analog]]\naddress = 16\niio = "ads1015"\nchannel = 0\n'
    board = parse_board(tomllib.loads(text), path, text)
    with pytest.raises(ConfigError, match=r":4: board.analog\[0\].iio: no IIO device named"):
        open_board(board, root=tmp_path)
    text = '[board]\n[[board.outputs]]\noutput = 1\nchip = "gpiochip0"\nline = 3\n'
    board = parse_board(tomllib.loads(text), path, text)
    with pytest.raises(ConfigError, match=r":4: board.outputs\[0\].chip: cannot open"):
        open_board(board, root=tmp_path)
    assert NAME == "linux"


def test_busy_lines_are_named_and_close_switches_outputs_off(tmp_path: Path) -> None:
    world = World(tmp_path)
    world.hw.set_output(2, True, world.now)
    text = '[board]\n[[board.outputs]]\noutput = 5\nchip = "gpiochip0"\nline = 27\n'
    path = tmp_path / "other.toml"
    board = parse_board(tomllib.loads(text), path, text)
    with pytest.raises(ConfigError, match=r"other.toml:5: board.outputs\[0\].line: .*busy"):
        LinuxHardware(board, root=tmp_path, chips={"gpiochip0": world.chip})
    world.hw.close()
    assert world.chip.history[-1] == (27, False)

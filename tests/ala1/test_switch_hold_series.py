"""§6.9 and §6.5.13: on-demand reads of switched and DS18B20 inputs.

- The switch hold runs from each measurement, so a series of consecutive reads keeps the
  sensor powered (regression: the hold ran from the first power-on, and a client polling
  ``read channel value`` every second waited for the advance again at t = 6 s).
- A line that starts waiting tells the hardware when it will read (``prepare``), so a backend
  with a slow acquisition (the Linux board's DS18B20) has fresh values by then.
"""

from __future__ import annotations

from ala1_module import Module

from sondalog.ala1.hardware import rom_code
from sondalog.backends.sim.logger import Analog, SimHardware, Thermometer
from sondalog.backends.sim.signals import constant


class PreparedHardware(SimHardware):
    """The simulated world, recording the instants the core asks the hardware to prepare."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__(**kwargs)  # type: ignore[arg-type]
        self.prepared: list[float] = []

    def prepare(self, t: float) -> None:
        self.prepared.append(t)


def switched_module(hw: SimHardware) -> Module:
    m = Module(hardware=hw)
    for setting in ("type 3", "address 16", "switch output 0", "format 0.1"):
        m.ok(f"write channel 1 {setting}")
    m.ok("write output 2 device 1 write output 2 address 6")
    m.ok("write channel 1 switch output 2 write channel 1 switch advance 3")
    return m


def test_each_read_renews_the_switch_hold() -> None:
    hw = SimHardware(analog=[Analog(16, constant(1.0), power=2)])
    m = switched_module(hw)  # command channel switch hold: 000005 (the default)
    assert m.settle("read channel 1 value") == b"1.0\r\nOK\r\n"  # waited the 3 s advance
    for _ in range(12):  # one client polling every second, well past the first hold
        m.advance(1.0)
        assert m.ask("read channel 1 value") == b"1.0\r\nOK\r\n"
        assert hw.outputs.get(2) is True
    m.advance(4.9)
    assert hw.outputs.get(2) is True  # 5 s after the last read
    m.advance(0.2)
    assert hw.outputs.get(2) is False
    assert m.ask("read channel 1 value") == b""  # off: the advance again


def test_a_longer_hold_is_renewed_too() -> None:
    hw = SimHardware(analog=[Analog(16, constant(1.0), power=2)])
    m = switched_module(hw)
    m.ok("write command channel switch hold 000100")
    assert m.settle("read channel 1 value") == b"1.0\r\nOK\r\n"
    m.advance(50.0)
    assert m.ask("read channel 1 value") == b"1.0\r\nOK\r\n"
    m.advance(50.0)  # 100 s after power-on, 50 s after the last read
    assert hw.outputs.get(2) is True
    assert m.ask("read channel 1 value") == b"1.0\r\nOK\r\n"


def test_a_waiting_read_prepares_the_hardware() -> None:
    hw = PreparedHardware(analog=[Analog(16, constant(1.0), power=2)])
    m = switched_module(hw)
    hw.prepared.clear()
    assert m.ask("read channel 1 value") == b""
    assert m.now + 3.0 in hw.prepared  # ready after the advance, in host time
    assert m.advance(3.0) == b"1.0\r\nOK\r\n"


def test_a_ds18b20_read_prepares_the_conversion() -> None:
    rom = rom_code(0x1234)
    hw = PreparedHardware(thermometers=[Thermometer(4, rom, constant(21.5))])
    m = Module(hardware=hw)
    m.ok("write device 2 type ds18b20 write device 2 address 4")
    m.ok("write channel 1 device 2 write channel 1 type 3 write channel 1 switch output 0")
    m.ok(f"write channel 1 address x {rom:X}")
    hw.prepared.clear()
    assert m.ask("read channel 1 value") == b""
    assert hw.prepared == [m.now + 0.75]  # the 750 ms conversion
    assert m.advance(0.75) == b"21.5\r\nOK\r\n"


def test_a_zero_hold_measures_then_switches_off() -> None:
    hw = SimHardware(analog=[Analog(16, constant(1.0), power=2)])
    m = switched_module(hw)
    m.ok("write command channel switch hold 000000")
    assert m.settle("read channel 1 value", limit=10) == b"1.0\r\nOK\r\n"  # it used to wait on
    m.advance(0.01)
    assert hw.outputs.get(2) is False  # off right after the measurement

"""A fault of a DS18B20 reads the same on the fast path (a column of instants, issue 24) as on
the instant-by-instant path: a bad CRC is no value on both (the control API's ``bad_crc``)."""

from __future__ import annotations

from sondalog.backends.sim.logger import SimHardware, Thermometer
from sondalog.backends.sim.signals import sine

T0 = 1_167_609_600.0
ROM = 0x2800000000000A28


def test_bad_crc_is_no_value_on_both_paths() -> None:
    sensor = Thermometer(pin=1, rom=ROM, signal=sine(21.5, 3.0, 86400.0, 0.0, T0))
    sim = SimHardware(thermometers=[sensor])
    times = [T0 + 60.0 * i for i in range(30)]
    for crc_error in (False, True):
        sensor.crc_error = crc_error
        for rom in (ROM, 0):  # addressed, and the only sensor on its pin
            one = [sim.ds18b20(1, rom, t) for t in times]
            column = sim.ds18b20_column(1, rom, times)
            assert column == [None if r is None else r[1] for r in one]
            assert all(v is None for v in column) == crc_error

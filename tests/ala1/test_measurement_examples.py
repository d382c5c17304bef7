"""The manual's examples that measure or read the record (§6.4-§6.8, §7-§10), byte for byte.

Each test wires a simulated module (sondalog.backends.sim.logger) so that its channels measure the
values the manual shows, then runs the manual's exchange.
"""

from __future__ import annotations

import subprocess

from ala1_module import T0, Module

from sondalog.ala1.hardware import rom_code
from sondalog.ala1.measure import channel_config
from sondalog.backends.sim.logger import Analog, PulseSource, SimHardware, Thermometer
from sondalog.backends.sim.signals import Schedule, constant
from sondalog.protocol.tables import build_files


def steps(*values: float, every: float = 3600.0, first: float = 1800.0) -> Schedule:
    """A signal holding values[0] until ``first`` s after T0, then each next value ``every``."""
    points = [(0.0, values[0])] + [(first + every * i, v) for i, v in enumerate(values[1:])]
    return Schedule(points, T0, False, False)


def analog_channel(m: Module, ch: int, address: int, fmt: str = "0.1", mult: str = "1") -> None:
    m.ok(f"write channel {ch} type 3")
    m.ok(f"write channel {ch} address {address}")
    m.ok(f"write channel {ch} switch output 0")
    m.ok(f"write channel {ch} format {fmt}")
    m.ok(f"write channel {ch} cal mult value {mult}")


def four_channels(ch1: float, ch2: float, supply: float, ch4: float) -> Module:
    """The §6.8.3 / §6.5.8 module: channel 3 measures the supply voltage."""
    hw = SimHardware(
        supply=constant(supply),
        analog=[Analog(16, constant(ch1 / 10)), Analog(17, constant(abs(ch2) / 10)),
                Analog(18, constant(ch4 / 10))],
    )  # fmt: skip
    m = Module(hardware=hw)
    m.ok("write channel max number 4")
    analog_channel(m, 1, 16, mult="10")
    analog_channel(m, 2, 17, mult="-10" if ch2 < 0 else "10")
    analog_channel(m, 4, 18, mult="10")
    m.ok("write channel 3 switch output 1")  # factory: the supply divider's switch
    return m


def test_6_5_8_value(tmp_path: object) -> None:
    m = four_channels(2.0, 10.51, 13.8, 12.0)
    m.ok("write channel 2 format 0.2")
    assert m.settle("readchannelvalue") == b"2.0,10.51,13.8,12.0\r\nOK\r\n"
    assert m.ask("readchannel2value") == b"10.51\r\nOK\r\n"


def test_6_5_10_4_calibration_example() -> None:
    m = four_channels(2.0, 10.5, 13.8, 12.0)
    assert m.settle("read channel 3 value") == b"13.8\r\nOK\r\n"
    assert m.ask("write channel 3 cal mult value 10") == b"OK\r\n"
    assert m.ask("read channel 3 value") == b"138.0\r\nOK\r\n"
    assert m.ask("write channel 3 cal add value -0.8") == b"OK\r\n"
    assert m.ask("read channel 3 value") == b"137.2\r\nOK\r\n"


def test_6_8_3_zmer() -> None:
    m = four_channels(2.0, -10.5, 13.8, 12.0)
    assert m.ask("write command 1 name zmer") == b"OK\r\n"
    assert m.ask("write command 1 value/read channel value/") == b"OK\r\n"
    assert m.settle("zmer") == b"2.0,-10.5,13.8,12.0\r\nOK\r\n"


def test_6_8_3_ctizaznam() -> None:
    hw = SimHardware(
        supply=steps(13.8, 13.8, 14.1, 14.3),
        analog=[Analog(16, steps(0.0, 0.04, 0.2, 0.17)),
                Analog(17, steps(0.95, 1.05, 1.2, 1.22)), Analog(18, constant(1.2))],
    )  # fmt: skip
    m = Module(hardware=hw)
    m.ok("write date 20070630235959")
    m.ok("write channel max number 4")
    analog_channel(m, 1, 16, mult="10")
    analog_channel(m, 2, 17, mult="10")
    analog_channel(m, 4, 18, mult="10")
    m.error("write channel sampling period 01 01 01 01")  # several channels: all six digits
    m.ok("write channel sampling period 010000 010000 010000 010000")
    m.ok("write channel sampling start 20070701000000 20070701000000 20070701000000 20070701000000")
    m.advance(4 * 3600)
    assert m.ask("write command 1 name ctizaznam") == b"OK\r\n"
    assert m.ask("write command 1 value/read record 4 from date &/") == b"OK\r\n"
    assert m.ask("ctizaznam200707") == (
        b"20070701000000.0,1,0.0,9.5,13.8,12.0\r\n"
        b"20070701010000.0,1,0.4,10.5,13.8,12.0\r\n"
        b"20070701020000.0,1,2.0,12.0,14.1,12.0\r\n"
        b"20070701030000.0,1,1.7,12.2,14.3,12.0\r\n"
        b"OK\r\n"
    )


def test_6_6_1_1_read_record_from_date() -> None:
    hw = SimHardware(
        supply=steps(13.2, 13.2, 13.2, 13.3),
        analog=[Analog(16, steps(1.4, 1.4, 1.1, 1.1)), Analog(17, steps(0.65, 0.65, 0.66, 0.66))],
    )
    m = Module(hardware=hw)
    m.ok("write date 20070716085959")
    m.ok("write channel max number 3")
    analog_channel(m, 1, 16, mult="2")
    analog_channel(m, 2, 17, fmt="0.2")
    m.ok("write channel 2 cal add value -2")
    m.ok("write channel 3 switch output 0")
    m.ok("write output 1 value 1")  # the supply divider powered by hand
    m.ok("write channel 010203 sampling period 010000 010000 010000")
    m.ok("write channel 1 2 3 sampling start 20070716090000 20070716090000 20070716090000")
    m.advance(3 * 3600 + 1)
    assert m.ask("read record 100 from date/20070716090000.0/") == (
        b"20070716100000.0,1,2.8,-1.35,13.2\r\n"
        b"20070716110000.0,1,2.2,-1.34,13.2\r\n"
        b"20070716120000.0,1,2.2,-1.34,13.3\r\n"
        b"OK\r\n"
    )
    # without the counter: from the oldest row at or after the point
    assert m.ask("read record 1 from date/20070716090000/").startswith(b"20070716090000.0,1,")
    assert m.ask("read record 2 from date*2007071611*") == (
        b"20070716110000.0,1,2.2,-1.34,13.2\r\n20070716120000.0,1,2.2,-1.34,13.3\r\nOK\r\n"
    )
    assert m.ask("read record from start").startswith(b"20070716090000.0,1,2.8,-1.35,13.2")


def test_9_rows_of_channels_sampled_at_different_times() -> None:
    hw = SimHardware(
        supply=constant(13.2),
        analog=[Analog(16, constant(1.4)), Analog(17, constant(1.3)), Analog(18, constant(0.523)),
                Analog(19, constant(0.818))],
    )  # fmt: skip
    m = Module(hardware=hw)
    m.ok("write date 20050716093959")
    m.ok("write channel max number 5")
    analog_channel(m, 1, 16, mult="2")
    analog_channel(m, 2, 17)
    m.ok("write channel 2 cal add value -2.6")
    analog_channel(m, 3, 18, fmt="0.2", mult="10")
    analog_channel(m, 4, 19, fmt="0.2", mult="10")
    m.ok("write channel 5 type 1 write channel 5 switch output 0")
    m.ok("write output 1 value 1")
    m.ok("write channel 1 2 3 4 5 sampling period 002000 004000 004000 002000 004000")
    m.ok("write channel sampling start 20050716094000 20050716094000 20050716094000"
         " 20050716094000 20050716094000")  # fmt: skip
    m.advance(1 + 20 * 60)
    assert m.ask("readrecord100fromdate*2005071609*") == (
        b"20050716094000.0,1,2.8,-1.3,5.23,8.18,13.2\r\n20050716100000.0,1,2.8,,,8.18,\r\nOK\r\n"
    )


def test_8_4_1_crcsum_of_a_record_read() -> None:
    hw = SimHardware(supply=constant(12.6), analog=[Analog(16, constant(1.475)),
                                                    Analog(17, constant(1.56))])  # fmt: skip
    m = Module(hardware=hw)
    m.ok("write date 20050501065959")
    m.ok("write channel max number 3")
    analog_channel(m, 1, 16, fmt="0.2", mult="2")
    analog_channel(m, 2, 17, mult="10")
    m.ok("write channel 3 switch output 0")
    m.ok("write output 1 value 1")
    m.ok("write channel 1 2 3 sampling period 003000 003000 003000")
    m.ok("write channel sampling start 20050501070000 20050501070000 20050501070000")
    m.advance(1 + 5 * 1800)
    answer = m.ask("crcsum read record 6 from start")
    lines = answer.split(b"\r\n")
    assert lines[0] == b"20050501070000.0,1,2.95,15.6,12.6"
    assert len(lines) == 9 and lines[7] == b"OK"
    body = b"".join(line + b"\r\n" for line in lines[:6])
    crc, length = subprocess.run(["cksum"], input=body, capture_output=True).stdout.split()[:2]
    assert lines[6] == crc + b"," + length
    assert length == b"210"  # the manual's length for six 33-character rows


def test_7_1_7_2_8_5_chaining_and_headers_on_values() -> None:
    hw = SimHardware(analog=[Analog(16, constant(1.852)), Analog(17, constant(1.05))])
    m = Module(hardware=hw)
    m.ok("write channel max number 2")
    analog_channel(m, 1, 16, fmt="0.2", mult="10")
    analog_channel(m, 2, 17, mult="10")
    assert m.ask("readtext/Zde je zmerena hodnota prvnio kanalu/readchannel1value") == (
        b"Zde je zmerena hodnota prvnio kanalu\r\n18.52\r\nOK\r\n"
    )
    m.ok("write channel 1 name/Teplota vzduchu/ write channel 1 format 0.1")
    m.ok("write channel 1 cal mult value 13.07")
    assert m.ask("number1 read channel 1 name 1 value") == (
        b"1,Teplota vzduchu\r\n2,24.2\r\n3,OK\r\n"
    )
    assert m.ask("number1readchannel2value") == b"1,10.5\r\n2,OK\r\n"
    m.ok("write date 20060701090532")
    assert m.ask("date read channel 2 value") == (b"20060701090532,10.5\r\n20060701090532,OK\r\n")
    assert m.ask("quiet startline/Teplota: /endline/ stupnu/ read channel 2 value") == (
        b"Teplota: 10.5 stupnu\r\n"
    )


def test_6_4_3_1_1_detection_address() -> None:
    first, second = rom_code(0x00000008D5E4FD), rom_code(0x1234567890AB)
    hw = SimHardware(thermometers=[Thermometer(4, first, constant(21.3))])
    m = Module(hardware=hw)
    m.ok("write device 2 type ds18b20")
    m.ok("write device 2 address 4")
    m.ok("write channel 1 device 2")
    m.ok("write channel 1 type 3 write channel 1 switch output 0")
    m.ok("write channel 1 address x FF00")
    assert m.settle("read channel 1 value") == b"21.3\r\nOK\r\n"
    learned = int(m.read("read channel 1 address x"), 16)
    assert learned == first & ~0xFF and learned | 0x28 == first
    # the stored code is still a detection address: the next sensor can be learned
    hw.thermometers = [Thermometer(4, second, constant(-5.25))]
    assert m.settle("read channel 1 value") == b"-5.3\r\nOK\r\n"
    assert int(m.read("read channel 1 address x"), 16) | 0x28 == second


def test_ds18b20_parallel_sensors_by_rom_code() -> None:
    a, b = rom_code(1), rom_code(2)
    hw = SimHardware(
        thermometers=[Thermometer(3, a, constant(20.0625)), Thermometer(3, b, constant(-3.5))]
    )
    m = Module(hardware=hw)
    m.ok("write device 5 type ds18b20")
    m.ok("write device 5 address 3")
    m.ok("write channel max number 3")
    for ch, address in ((1, f"x {a:X}"), (2, f"x {b:X}"), (3, "0")):
        m.ok(f"write channel {ch} device 5")
        m.ok(f"write channel {ch} address {address}")
        m.ok(f"write channel {ch} type 3 write channel {ch} switch output 0")
        m.ok(f"write channel {ch} format 0.4")
    answer = m.ask("read channel value")
    assert answer == b""  # the 750 ms conversion runs first
    assert m.advance(0.74) == b""
    assert m.advance(0.01) == b"20.0625,-3.5000,\r\nOK\r\n"  # address 0 with two sensors: none


def test_switched_sensor_needs_its_advance_and_stays_on_for_hold() -> None:
    hw = SimHardware(analog=[Analog(16, constant(1.0), power=2)])
    m = Module(hardware=hw)
    analog_channel(m, 1, 16)
    m.ok("write output 2 device 1 write output 2 address 6")
    m.ok("write channel 1 switch output 2 write channel 1 switch advance 3")
    assert m.ask("read channel 1 value") == b""
    assert hw.outputs.get(2) is True
    assert m.advance(2.9) == b""
    assert m.advance(0.1) == b"1.0\r\nOK\r\n"
    assert m.ask("read channel 1 value") == b"1.0\r\nOK\r\n"  # still on: no new wait
    m.advance(5.5)  # command channel switch hold 000005 ran out
    assert hw.outputs.get(2) is False
    m.ok("write output 2 value 0")  # forced off: the sensor has no power
    assert m.ask("read channel 1 value") == b"\r\nOK\r\n"


def test_output_values_drive_the_hardware() -> None:
    hw = SimHardware()
    m = Module(hardware=hw)
    m.ok("write output 7 device 8")
    m.ok("write output 7 value 1")
    assert hw.outputs.get(7) is True
    m.ok("write output 7 value 0")
    assert hw.outputs.get(7) is False


TABLE1 = b"100.8 550.9\n351.65 1000\n893 1790.53\n"
TABLE2 = b"3\n100.8 550.9\n351.65 1000\n893 1790.53\n4\n100.7 560\n351 1008\n890 1800.2\n"


def table_module() -> tuple[Module, SimHardware]:
    hw = SimHardware(analog=[Analog(16, constant(1.0)), Analog(17, constant(1.0))])
    m = Module(hardware=hw)
    listing, data = build_files({"tabulka1": TABLE1, "tabulka2": TABLE2})
    assert listing == b"tabulka1 36\ntabulka2 70\n"  # §10.4
    m.ok("write file record size 983040 write file list size 256 write file data size 51200")
    m.engine.state.write_file("list", listing)
    m.engine.state.write_file("data", data)
    m.ok("write channel max number 2")
    analog_channel(m, 1, 16, fmt="0.2")
    m.ok("write channel 1 convert file name/tabulka1/")
    m.ok("write channel 2 type 9 write channel 2 format 0.2")
    m.ok("write channel 2 device all 1,1 write channel 2 address all 16,17")
    m.ok("write channel 2 switch output all 0,0")
    m.ok("write channel 2 convert 1 file name/tabulka2/")
    return m, hw


def test_10_2_one_dimensional_table() -> None:
    m, hw = table_module()
    # the input is volts * 1000 (cal2 mult 1000): 50 below, 226.225 inside, 1000 above
    m.ok("write channel 1 cal2 mult 1000")
    for volts in (0.05, 0.1008, 0.226225, 0.6224, 1.0):  # below, edge, inside both, above
        hw.set_signal("analog:16", volts)
        x = round(volts / 2.5 * 4095) / 4095 * 2.5 * 1000  # what the 12-bit ADC sees, in mV
        assert abs(float(m.read("read channel 1 value")) - _t1(x)) <= 0.005, volts
    hw.set_signal("analog:16", 0.01)
    assert m.read("read channel 1 value") == "550.90"  # below the table: the first row
    hw.set_signal("analog:16", 2.0)
    assert m.read("read channel 1 value") == "1790.53"  # above: the last row


def _t1(x: float) -> float:
    xs, ys = (100.8, 351.65, 893), (550.9, 1000, 1790.53)
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    i = 1 if x <= xs[1] else 2
    return ys[i - 1] + (ys[i] - ys[i - 1]) * (x - xs[i - 1]) / (xs[i] - xs[i - 1])


def test_10_3_two_dimensional_table() -> None:
    m, hw = table_module()
    m.ok("write channel 2 cal2 mult all 1000 4")  # first input in mV, parameter = 4 * volts
    cases = [
        # (first volts, second volts) -> the three interpolations of §10.3
        ((0.2, 0.8), 550.9 + (1000 - 550.9) * (200 - 100.8) / (351.65 - 100.8)),  # p = 3.2
        ((0.2, 0.5), 550.9 + (1000 - 550.9) * (200 - 100.8) / (351.65 - 100.8)),  # p < 3
        ((2.0, 1.2), 1800.2),  # p > 4, first input above the last row
        ((0.05, 1.2), 560.0),  # p > 4, first input below the first row
    ]
    for (v1, v2), expected in cases:
        hw.set_signal("analog:16", v1)
        hw.set_signal("analog:17", v2)
        value = float(m.read("read channel 2 value"))
        assert abs(value - expected) < 2.5, (v1, v2, value, expected)
    hw.set_signal("analog:16", 0.2)
    hw.set_signal("analog:17", 0.8)  # p = 3.2: 80 % region 3 + 20 % region 4
    x = round(0.2 / 2.5 * 4095) / 4095 * 2.5 * 1000
    p = round(0.8 / 2.5 * 4095) / 4095 * 2.5 * 4
    r3 = 550.9 + (1000 - 550.9) * (x - 100.8) / (351.65 - 100.8)
    r4 = 560 + (1008 - 560) * (x - 100.7) / (351 - 100.7)
    assert m.read("read channel 2 value") == f"{r3 + (r4 - r3) * (p - 3):.2f}"


def test_missing_or_malformed_table_yields_no_value() -> None:
    m, _ = table_module()
    m.ok("write channel 1 convert file name/nosuch/")
    assert m.ask("read channel 1 value") == b"\r\nOK\r\n"
    m.ok("write channel 1 convert file name/tabulka2/")  # a 2-D table for a type-3 channel
    assert m.ask("read channel 1 value") == b"\r\nOK\r\n"
    descending = b"893 1790.53\n351.65 1000\n100.8 550.9\n"  # same length, inputs descending
    m.engine.state.write_file("data", descending + TABLE2)
    m.ok("write channel 1 convert file name/tabulka1/")
    assert m.ask("read channel 1 value") == b"\r\nOK\r\n"
    reason = m.engine.state.measurer.why_no_value(channel_config(m.engine.state.begin(m.now), 1))
    assert reason is not None and "ascend" in reason


def test_pulses_per_period_and_timer_limit() -> None:
    hw = SimHardware(pulses=[PulseSource(True, 0, rate=7.0, origin=T0)])
    m = Module(hardware=hw)
    m.ok("write device 3 type msp430ta")
    m.ok("write channel 1 device 3 write channel 1 type 2 write channel 1 switch output 0")
    m.ok("write channel 1 format 0.0 write channel 1 sampling period 000010")
    m.ok("write channel 1 sampling start 20000101000000 write channel 1 record change 0")
    m.advance(30)
    rows = m.ask("read record 10 from start").split(b"\r\n")[:-2]
    assert [r.split(b",")[2] for r in rows] == [b"70"] * 4  # samples at 0, 10, 20 and 30 s

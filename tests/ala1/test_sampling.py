"""Scheduled sampling and the record conditions (§6.5.14-§6.5.16, spec notes §7)."""

from __future__ import annotations

from ala1_module import T0, Module

from sondalog.backends.sim.logger import Analog, PulseSource, SimHardware
from sondalog.backends.sim.signals import Schedule, constant


def module_with(signal: object, *, fmt: str = "0.2") -> tuple[Module, SimHardware]:
    hw = SimHardware(analog=[Analog(16, signal)])  # type: ignore[arg-type]
    m = Module(hardware=hw)
    m.ok("write date 20070301085959")  # one second before 09:00:00 at T0
    m.ok("write channel 1 type 3 write channel 1 address 16")
    m.ok("write channel 1 switch output 0")
    m.ok(f"write channel 1 format {fmt}")
    return m, hw


def rows(m: Module) -> list[str]:
    answer = m.ask("read record 100000 from start").decode()
    assert answer.endswith("OK\r\n")
    return answer.split("\r\n")[:-2]


def values(m: Module, field: int = 2) -> list[str]:
    return [r.split(",")[field] for r in rows(m)]


def series(*points: tuple[float, float]) -> Schedule:
    """Signal values at module times given as seconds after 09:00:00 (T0 + 1)."""
    return Schedule([(t + 1, v) for t, v in points], T0, False, False)


def test_6_5_15_average_of_sixty_one_minute_samples_every_hour() -> None:
    # a ramp sampled each minute: the hourly mean is the value at the middle of the hour
    ramp = series(*[(60 * k, k / 1000) for k in range(0, 200)])
    m, _ = module_with(ramp, fmt="0.4")
    m.ok("write channel 1 sampling period 000100")
    m.ok("write channel 1 average samples 60")
    m.ok("write channel 1 record change 0")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(3 * 3600)
    stamps = [r.split(",")[0] for r in rows(m)]
    assert stamps == ["20070301095900.0", "20070301105900.0", "20070301115900.0"]
    # samples 0..59 mV -> mean 29.5 mV, through a 12-bit ADC
    assert abs(float(values(m)[0]) - 0.0295) < 0.0007
    assert abs(float(values(m)[1]) - 0.0895) < 0.0007


def test_6_5_16_1_record_change_0_02() -> None:
    # last written 1.25; 1.24 and 1.26 are too small a change, 1.23 and 1.27 are not
    steps = [1.25, 1.24, 1.26, 1.23, 1.24, 1.25, 1.27, 1.27, 1.30]
    m, _ = module_with(series(*[(600 * i, v / 2) for i, v in enumerate(steps)]))
    m.ok("write channel 1 cal mult value 2")
    m.ok("write channel 1 sampling period 001000")
    m.ok("write channel 1 record change 0.02")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(600 * (len(steps) - 1) + 1)
    assert values(m) == ["1.25", "1.23", "1.25", "1.27", "1.30"]


def test_6_5_16_2_record_samples_6_every_hour() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write channel 4 type 3")  # unrelated channel, not sampled
    m.ok("write channel 1 sampling period 001000")
    m.ok("write channel 1 record change -1")  # only the samples condition
    m.ok("write channel 1 record samples 6")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(3 * 3600 + 1)
    assert [r.split(",")[0] for r in rows(m)] == [
        "20070301095000.0",
        "20070301105000.0",
        "20070301115000.0",
    ]


def test_change_and_samples_combined_forces_a_row_when_constant() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write channel 1 sampling period 001000")
    m.ok("write channel 1 record change 0.5")
    m.ok("write channel 1 record samples 6")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(2 * 3600 + 1)
    # first value (nothing recorded yet), then every sixth sample
    assert [r.split(",")[0][8:12] for r in rows(m)] == ["0900", "1000", "1100"]


def test_record_change_0_always_and_minus_1_never() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write channel 1 sampling period 000010")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(50)
    assert len(rows(m)) == 5
    m.ok("write record status clear")
    m.ok("write channel 1 record change -1")
    m.advance(100)
    assert rows(m) == []


def test_type_6_event_rule() -> None:
    hw = SimHardware(pulses=[PulseSource(True, 0, rate=0.0, origin=T0)])
    m = Module(hardware=hw)
    m.ok("write date 20070301085959")
    m.ok("write device 3 type msp430ta")
    m.ok("write channel 1 device 3 write channel 1 type 6 write channel 1 switch output 0")
    m.ok("write channel 1 format 0.0 write channel 1 sampling period 000100")
    m.ok("write channel 1 record change 3")
    m.ok("write channel 1 sampling start 20070301090000")
    counts = [0, 5, 4, 1, 0, 2, 3, 0, 0]
    for count in counts:
        hw.pulse_sources[0].rate = count / 60
        hw.pulse_sources[0].origin = m.now
        m.advance(60)
    # >= 3 is written, then one 0 when it stops holding, then nothing until it holds again
    assert values(m) == ["5", "4", "0", "3", "0"]


def test_past_start_moves_forward_by_whole_periods() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write date 20070301093000")
    m.now = T0  # keep the host clock; the module clock now reads 09:30:00
    m.ok("write channel 1 sampling start 20070301090000")  # 09:00 + 5 * 7 min = 09:35
    m.ok("write channel 1 sampling period 000700")
    m.advance(4 * 60 + 59)
    assert rows(m) == []
    m.advance(1)
    assert rows(m)[0].startswith("20070301093500.0,1,")


def test_start_0000_means_the_next_whole_hour() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write date 20070301093512")
    m.ok("write channel 1 sampling period 010000")
    m.ok("write channel 1 sampling start 0000")
    m.advance(24 * 60 + 47)
    assert rows(m) == []
    m.advance(1)
    assert [r.split(",")[0] for r in rows(m)] == ["20070301100000.0"]


def test_period_000000_stops_sampling() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write channel 1 sampling period 000010")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(21)
    m.ok("write channel 1 sampling period 000000")
    m.advance(100)
    assert len(rows(m)) == 3
    assert m.engine.next_deadline() is None


def test_channels_sampled_in_the_same_second_share_a_row() -> None:
    hw = SimHardware(analog=[Analog(16, constant(1.0)), Analog(17, constant(2.0))])
    m = Module(hardware=hw)
    m.ok("write date 20070301085959")
    m.ok("write channel max number 3")
    for ch, address in ((1, 16), (3, 17)):
        m.ok(f"write channel {ch} type 3 write channel {ch} address {address}")
        m.ok(f"write channel {ch} switch output 0")
    m.ok("write channel 1 3 sampling period 000100 000200")
    m.ok("write channel 1 3 sampling start 20070301090000 20070301090000")
    m.advance(4 * 60 + 1)
    assert rows(m) == [
        "20070301090000.0,1,1.0,,2.0",
        "20070301090100.0,1,1.0,,",
        "20070301090200.0,1,1.0,,2.0",
        "20070301090300.0,1,1.0,,",
        "20070301090400.0,1,1.0,,2.0",
    ]
    assert m.read("read channel sample") == "1.0,,2.0"
    assert m.read("read channel 3 record value") == "2.0"


def test_rows_in_one_second_are_told_apart_by_the_counter() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write text/a/ write text 7/b/ write text/c/")
    m.ok("write channel 1 value 4")
    assert rows(m) == [
        "20070301085959.0,3,a",
        "20070301085959.1,7,b",
        "20070301085959.2,3,c",
        "20070301085959.3,4,1.00",
    ]
    assert m.ask("read record 9 from date/20070301085959.1/").startswith(
        b"20070301085959.2,3,c\r\n"
    )


def test_write_value_does_not_disturb_averaging() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write channel 1 sampling period 000100")
    m.ok("write channel 1 average samples 3")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(61)
    m.ok("write channel 1 value")
    m.advance(120)
    assert [r.split(",")[1] for r in rows(m)] == ["2", "1"]
    assert rows(m)[1].startswith("20070301090200.0,1,")


def test_switched_sensor_is_powered_advance_seconds_before_the_sample() -> None:
    hw = SimHardware(analog=[Analog(16, constant(1.0), power=3)])
    m = Module(hardware=hw)
    m.ok("write date 20070301085900")
    m.ok("write channel 1 type 3 write channel 1 address 16")
    m.ok("write output 3 device 1 write output 3 address 6")
    m.ok("write channel 1 switch output 3 write channel 1 switch advance 10")
    m.ok("write channel 1 sampling period 000100 write channel 1 sampling start 20070301090000")
    m.advance(49)
    assert not hw.outputs.get(3)
    m.advance(1)
    assert hw.outputs.get(3)  # 10 s before 09:00:00
    m.advance(10)
    assert not hw.outputs.get(3)  # off after the sample
    assert rows(m) == ["20070301090000.0,1,1.0"]


def test_setting_the_clock_reschedules() -> None:
    m, _ = module_with(constant(1.0))
    m.ok("write channel 1 sampling period 010000")
    m.ok("write channel 1 sampling start 20070301090000")
    m.advance(2)
    m.ok("write date 20070301095959")
    m.advance(1)
    assert [r.split(",")[0] for r in rows(m)] == ["20070301090000.0", "20070301100000.0"]

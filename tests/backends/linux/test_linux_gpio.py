"""GPIO: pulse counting from edge events with kernel timestamps; outputs; the real chip."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from sondalog.backends.linux.fakegpio import FakeChip
from sondalog.backends.linux.gpio import Edge, GpiodChip, PulseCounter


def test_counts_in_half_open_windows_by_event_time() -> None:
    host = [1000.0]
    chip = FakeChip(clock=lambda: host[0])  # the chip's clock = host clock (seconds)
    edges = chip.request_edges([17], "t", edge="falling", bias="pull-up", debounce=0.005)
    counter = PulseCounter(lambda: host[0])
    counter.watch(17)
    for t in (1000.5, 1001.0, 1001.999, 1002.0):
        chip.pulse_at(17, t)
    chip.pulse_at(17, 1001.5, rising=True)  # a rising edge: not counted on a falling input
    host[0] = 1010.0  # read late: the kernel timestamps still place each pulse exactly
    counter.take(edges.read(), edges.clock_ns())
    assert counter.count(17, 1000.0, 1001.0) == 1
    assert counter.count(17, 1001.0, 1002.0) == 2
    assert counter.count(17, 1002.0, 1003.0) == 1
    assert counter.count(17, 900.0, 2000.0) == 4
    assert counter.count(18, 900.0, 2000.0) == 0
    assert chip.edge_settings[17] == ("falling", "pull-up", 0.005)


def test_timestamps_in_another_clock_are_converted() -> None:
    chip = FakeChip()
    chip.now_ns = 5_000_000_000  # the kernel's monotonic clock: 5 s since boot
    edges = chip.request_edges([4], "t", edge="both", bias="as-is", debounce=0.0)
    counter = PulseCounter(lambda: 1_700_000_000.0)
    counter.watch(4)
    chip.inject(4, 4_000_000_000)  # 1 s before "now"
    counter.take(edges.read(), edges.clock_ns())
    assert counter.count(4, 1_699_999_998.9, 1_699_999_999.1) == 1


def test_old_pulses_are_forgotten() -> None:
    host = [0.0]
    counter = PulseCounter(lambda: host[0])
    counter.watch(1)
    counter.take([Edge(1, 0, False)], 0)
    host[0] = 2 * 86400.0
    counter.take([], 0)
    assert counter.count(1, -1.0, 1.0) == 0


def test_outputs_and_busy_lines() -> None:
    chip = FakeChip()
    outputs = chip.request_outputs({27: False}, "t")
    outputs.set(27, True)
    assert chip.levels == {27: True}
    with pytest.raises(OSError, match="busy"):
        chip.request_edges([27], "t", edge="both", bias="as-is", debounce=0.0)
    assert chip.offset_of("GPIO17") == 17
    with pytest.raises(ValueError):
        chip.offset_of("GPIO99")


def test_real_gpiod_refuses_a_missing_chip(tmp_path: Path) -> None:
    with pytest.raises(OSError):
        GpiodChip(str(tmp_path / "gpiochip0"))
    with pytest.raises(OSError):
        GpiodChip("/dev/null")  # a character device, but not a GPIO chip


@pytest.mark.hardware
def test_real_chip_output_and_edges() -> None:
    """On a board: SONDALOG_GPIO_CHIP=/dev/gpiochip0, SONDALOG_GPIO_LOOP=OUT,IN (two lines
    wired together): toggling OUT produces counted edges on IN."""
    import time

    chip_path = os.environ.get("SONDALOG_GPIO_CHIP", "/dev/gpiochip0")
    out_line, in_line = map(int, os.environ.get("SONDALOG_GPIO_LOOP", "20,21").split(","))
    chip = GpiodChip(chip_path)
    try:
        edges = chip.request_edges([in_line], "t", edge="rising", bias="as-is", debounce=0.0)
        outputs = chip.request_outputs({out_line: False}, "t")
        counter = PulseCounter(time.time)
        counter.watch(in_line)
        t0 = time.time()
        for _ in range(5):
            outputs.set(out_line, True)
            time.sleep(0.01)
            outputs.set(out_line, False)
            time.sleep(0.01)
        counter.take(edges.read(), edges.clock_ns())
        assert counter.count(in_line, t0, time.time() + 1) == 5
    finally:
        chip.close()
